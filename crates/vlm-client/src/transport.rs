//! The one HTTP path to a model server: a `ureq` agent (keep-alive pool, rustls, proxies from
//! `HTTPS_PROXY`/`HTTP_PROXY`/`NO_PROXY`) and a JSON POST with one deadline per attempt
//! (DNS, connect, request and reply together) and bounded retries: exponential backoff with
//! jitter, or the server's `Retry-After` on 429 and 503 when it asks for no more than
//! [`RetryPolicy::max_wait`].

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crate::error::{ChatError, ChatErrorKind};

/// Largest reply body read (a chat reply is a few kilobytes).
const MAX_BODY_BYTES: u64 = 64 << 20;

/// Deadline and retries of one logical request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RetryPolicy {
    /// For one attempt: DNS, connect, request and reply.
    pub timeout: Duration,
    /// Further attempts after a transient failure (connection, timeout, 408, 429, 5xx).
    pub max_retries: u32,
    /// Wait before the first retry, doubled for each further one, times a jitter in [0.5, 1).
    pub backoff: Duration,
    /// The longest wait a `Retry-After` may ask for; a longer one ends the retries.
    pub max_wait: Duration,
}

impl Default for RetryPolicy {
    fn default() -> Self {
        RetryPolicy {
            timeout: Duration::from_secs(120),
            max_retries: 3,
            backoff: Duration::from_millis(500),
            max_wait: Duration::from_secs(60),
        }
    }
}

/// A successful POST: the 2xx body, the attempts it took and the time spent waiting between
/// them.
#[derive(Debug, Clone)]
pub struct Delivered {
    /// The 2xx reply's body (at most 64 MiB).
    pub body: Vec<u8>,
    /// Attempts made, the successful one included.
    pub attempts: u32,
    /// Time slept between attempts (backoff or `Retry-After`).
    pub waited: Duration,
    /// Time from the start of the first attempt to the body read, waits included.
    pub elapsed: Duration,
}

/// An agent for `timeout`-bounded attempts to `url` (the base URL: its scheme and host choose
/// the proxy, [`crate::proxy`]; a proxy variable that names no usable proxy is a bad URL).
/// Statuses are returned, not raised, and redirects are not followed: a client following a
/// 301, 302 or 303 sends the POST again as a GET, with no body, whose failure would then be
/// reported under the first URL; the 3xx comes back as a status naming where the server points
/// ([`ChatErrorKind::Status`]). Connections
/// are kept alive and reused unless the environment sets `NSEA_HTTP_KEEPALIVE=0`, which opens
/// one connection per request (for servers that mishandle keep-alive, and to measure what
/// keep-alive saves).
pub fn agent(timeout: Duration, url: &str) -> Result<ureq::Agent, ChatErrorKind> {
    // The proxy for this URL's scheme and host ([`crate::proxy`]), or none.
    let proxy = crate::proxy::proxy_for(url).as_ref().map(crate::proxy::ureq_proxy).transpose()?;
    let mut config = ureq::Agent::config_builder()
        .timeout_global(Some(timeout))
        .http_status_as_error(false)
        .max_redirects(0)
        .proxy(proxy)
        .user_agent(concat!("nsea-vlm-client/", env!("CARGO_PKG_VERSION")));
    if std::env::var("NSEA_HTTP_KEEPALIVE").is_ok_and(|v| v == "0") {
        config = config.max_idle_connections(0).max_idle_connections_per_host(0);
    }
    Ok(config.build().into())
}

/// The API key in the environment variable `name`: set, not empty, and a value an HTTP header
/// can carry (printable ASCII; a newline or a non-ASCII character failed at the first request,
/// retried as a broken connection, naming no variable). Unset, empty or not Unicode:
/// [`ChatErrorKind::MissingApiKey`]; otherwise unsendable: [`ChatErrorKind::BadInput`].
pub fn api_key_from_env(name: &str) -> Result<String, ChatErrorKind> {
    // White space around the key (a file's last newline) is no part of it.
    let value = std::env::var(name).ok().map(|value| value.trim().to_string()).filter(|value| !value.is_empty());
    let value = value.ok_or_else(|| ChatErrorKind::MissingApiKey(name.to_string()))?;
    if let Some(c) = value.chars().find(|c| !(' '..='~').contains(c)) {
        return Err(ChatErrorKind::BadInput(format!(
            "the API key variable `{name}` holds {}, which an HTTP header cannot carry",
            if c.is_ascii() { format!("the control character {:?}", c) } else { format!("the non-ASCII character {c:?}") }
        )));
    }
    Ok(value)
}

/// `url` without the credentials it may hold (`http://user:pw@host/v1` → `http://…@host/v1`),
/// for messages about a URL that [`check_url`] refuses.
pub fn redacted(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else { return url.to_string() };
    let (authority, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
    match authority.rsplit_once('@') {
        Some((_, host)) => format!("{scheme}://…@{host}{path}"),
        None => url.to_string(),
    }
}

/// Checks that `url` is `http(s)://host[...]`, without credentials (a user and password in a
/// URL would be written into a run's configuration and messages; a key goes in an environment
/// variable).
pub fn check_url(url: &str) -> Result<(), ChatErrorKind> {
    let rest = url
        .strip_prefix("http://")
        .or_else(|| url.strip_prefix("https://"))
        .ok_or_else(|| ChatErrorKind::BadUrl(format!("`{url}`: expected http://host[:port][/path] or https://...")))?;
    let authority = rest.split('/').next().unwrap_or_default();
    if authority.is_empty() || authority.starts_with(':') {
        return Err(ChatErrorKind::BadUrl(format!("`{url}`: no host")));
    }
    if authority.contains('@') {
        // Named without the credentials, which this message would print.
        let host = authority.rsplit('@').next().unwrap_or_default();
        return Err(ChatErrorKind::BadUrl(format!(
            "a URL with credentials (…@{host}): they would be written into the run's configuration and messages; give a key by the variable holding it (--api-key-env)"
        )));
    }
    if url.contains(['?', '#', ' ']) {
        return Err(ChatErrorKind::BadUrl(format!("`{url}`: a query, fragment or space in a base URL")));
    }
    url.parse::<ureq::http::Uri>().map_err(|e| ChatErrorKind::BadUrl(format!("`{url}`: {e}")))?;
    // A port past 65535 parses (the URI keeps no port then), then fails as a connection
    // refused after every retry.
    let host = authority.rsplit('@').next().unwrap_or(authority);
    if !host.ends_with(']')
        && let Some((_, port)) = host.rsplit_once(':')
        && !port.parse::<u16>().is_ok_and(|p| p > 0)
    {
        return Err(ChatErrorKind::BadUrl(format!("`{url}`: port {port} is not one from 1 to 65535")));
    }
    Ok(())
}

/// POSTs `body` to `url` under `policy`; a non-2xx status, a transport failure or a timeout
/// after the last attempt is a [`ChatError`] carrying the attempts and the elapsed time.
pub fn post_json(agent: &ureq::Agent, url: &str, body: &[u8], bearer: Option<&str>, policy: &RetryPolicy) -> Result<Delivered, ChatError> {
    send(agent, url, Some(body), bearer, policy)
}

/// GETs `url` under `policy`, as [`post_json`] posts (a server's model list).
pub fn get_json(agent: &ureq::Agent, url: &str, bearer: Option<&str>, policy: &RetryPolicy) -> Result<Delivered, ChatError> {
    send(agent, url, None, bearer, policy)
}

/// A connection failure through a proxy names it and its variable: it was reported as the
/// model server's (`connection refused`, or a host name that did not resolve for an address).
fn through_proxy(kind: ChatErrorKind, url: &str) -> ChatErrorKind {
    match (kind, crate::proxy::proxy_for(url)) {
        (ChatErrorKind::Connect(why), Some(proxy)) => {
            ChatErrorKind::Connect(format!("{why} (through the proxy {} from {})", redacted(&proxy.url), proxy.variable))
        }
        (ChatErrorKind::Io(why), Some(proxy)) => {
            ChatErrorKind::Io(format!("{why} (through the proxy {} from {})", redacted(&proxy.url), proxy.variable))
        }
        (kind, _) => kind,
    }
}

/// One logical request, a POST of `body` or a GET, with the policy's retries.
fn send(agent: &ureq::Agent, url: &str, body: Option<&[u8]>, bearer: Option<&str>, policy: &RetryPolicy) -> Result<Delivered, ChatError> {
    let start = Instant::now();
    let mut attempts = 0;
    let mut waited = Duration::ZERO;
    loop {
        attempts += 1;
        let kind = match attempt(agent, url, body, bearer, policy.timeout) {
            Ok(body) => return Ok(Delivered { body, attempts, waited, elapsed: start.elapsed() }),
            Err(kind) => kind,
        };
        let wait = if kind.is_transient() && attempts <= policy.max_retries { retry_wait(&kind, attempts, policy) } else { None };
        match wait {
            Some(wait) => {
                std::thread::sleep(wait);
                waited += wait;
            }
            None => return Err(ChatError { kind: through_proxy(kind, url), url: url.to_string(), attempts, elapsed: start.elapsed() }),
        }
    }
}

/// How long to wait before attempt `attempts + 1`, or `None` when the server's `Retry-After`
/// asks for longer than the policy allows.
pub(crate) fn retry_wait(kind: &ChatErrorKind, attempts: u32, policy: &RetryPolicy) -> Option<Duration> {
    if let ChatErrorKind::Status { status: 429 | 503, retry_after: Some(asked), .. } = kind {
        return (*asked <= policy.max_wait).then_some(*asked);
    }
    let exponential = policy.backoff.saturating_mul(2u32.saturating_pow(attempts.saturating_sub(1)));
    Some(exponential.mul_f64(0.5 + 0.5 * jitter()).min(policy.max_wait))
}

/// A number in [0, 1) that differs between calls and processes (no cryptographic claim).
fn jitter() -> f64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64);
    let mut x = nanos ^ COUNTER.fetch_add(0x9e37_79b9_7f4a_7c15, Ordering::Relaxed) ^ u64::from(std::process::id()) << 32;
    // splitmix64's finaliser
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^= x >> 31;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

fn attempt(agent: &ureq::Agent, url: &str, body: Option<&[u8]>, bearer: Option<&str>, timeout: Duration) -> Result<Vec<u8>, ChatErrorKind> {
    // The key, on a POST or a GET alike (ureq types the two builders apart).
    fn authorized<B>(request: ureq::RequestBuilder<B>, bearer: Option<&str>) -> ureq::RequestBuilder<B> {
        match bearer {
            Some(token) => request.header("Authorization", &format!("Bearer {token}")),
            None => request,
        }
    }
    let sent = match body {
        Some(body) => {
            authorized(agent.post(url).header("Content-Type", "application/json"), bearer).header("Accept", "application/json").send(body)
        }
        None => authorized(agent.get(url), bearer).header("Accept", "application/json").call(),
    };
    let mut response = sent.map_err(|e| classify(e, timeout))?;
    let status = response.status().as_u16();
    let retry_after = response.headers().get("retry-after").and_then(|v| v.to_str().ok()).and_then(parse_retry_after);
    let location = response.headers().get("location").map(|v| String::from_utf8_lossy(v.as_bytes()).chars().take(500).collect::<String>());
    let bytes = response.body_mut().with_config().limit(MAX_BODY_BYTES).read_to_vec().map_err(|e| classify(e, timeout))?;
    if (200..300).contains(&status) {
        Ok(bytes)
    } else {
        let text = String::from_utf8_lossy(&bytes);
        let mut body = match location {
            // What to do about it, in place of a redirect page's HTML.
            Some(to) if (300..400).contains(&status) => format!("redirected to {to}; requests follow no redirect: name that URL"),
            _ => text.chars().take(500).collect(),
        };
        // A server or proxy that echoes the request's header would have the key printed.
        if let Some(key) = bearer.filter(|key| !key.is_empty()) {
            body = body.replace(key, "[the API key]");
        }
        Err(ChatErrorKind::Status { status, body, retry_after })
    }
}

/// A `ureq` error as a [`ChatErrorKind`].
pub(crate) fn classify(error: ureq::Error, timeout: Duration) -> ChatErrorKind {
    use std::io::ErrorKind;
    match error {
        ureq::Error::Timeout(_) => ChatErrorKind::Timeout(timeout),
        ureq::Error::HostNotFound => ChatErrorKind::Connect("host not found".into()),
        ureq::Error::ConnectionFailed => ChatErrorKind::Connect("connection failed".into()),
        ureq::Error::BadUri(uri) => ChatErrorKind::BadUrl(uri),
        ureq::Error::BodyExceedsLimit(limit) => ChatErrorKind::MalformedReply(format!("reply larger than {limit} bytes")),
        ureq::Error::Io(e) => match e.kind() {
            ErrorKind::TimedOut | ErrorKind::WouldBlock => ChatErrorKind::Timeout(timeout),
            ErrorKind::ConnectionRefused | ErrorKind::AddrNotAvailable | ErrorKind::HostUnreachable | ErrorKind::NetworkUnreachable => {
                ChatErrorKind::Connect(e.to_string())
            }
            _ => ChatErrorKind::Io(e.to_string()),
        },
        e @ (ureq::Error::Tls(_) | ureq::Error::Rustls(_) | ureq::Error::ConnectProxyFailed(_) | ureq::Error::InvalidProxyUrl) => {
            ChatErrorKind::Connect(e.to_string())
        }
        other => ChatErrorKind::Io(other.to_string()),
    }
}

/// `Retry-After` as delta-seconds or an HTTP date (IMF-fixdate), as a wait from now.
pub(crate) fn parse_retry_after(value: &str) -> Option<Duration> {
    let value = value.trim();
    if let Ok(seconds) = value.parse::<u64>() {
        return Some(Duration::from_secs(seconds));
    }
    let at = parse_http_date(value)?;
    let now = SystemTime::now().duration_since(UNIX_EPOCH).ok()?.as_secs();
    Some(Duration::from_secs(at.saturating_sub(now)))
}

/// `Sun, 06 Nov 1994 08:49:37 GMT` as seconds since the Unix epoch.
fn parse_http_date(value: &str) -> Option<u64> {
    let (_, rest) = value.split_once(", ")?;
    let mut parts = rest.split(' ');
    let day: u64 = parts.next()?.parse().ok()?;
    let month_name = parts.next()?;
    let month =
        ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"].iter().position(|m| *m == month_name)? as u64
            + 1;
    let year: u64 = parts.next()?.parse().ok()?;
    let mut clock = parts.next()?.split(':').map(|p| p.parse::<u64>().ok());
    let (hour, minute, second) = (clock.next()??, clock.next()??, clock.next()??);
    // IMF-fixdate's year has four digits: a larger one would overflow the day count below.
    if parts.next()? != "GMT" || !(1..=31).contains(&day) || !(1970..=9999).contains(&year) || hour > 23 || minute > 59 || second > 60 {
        return None;
    }
    // Days from 1970-01-01 to the date (Howard Hinnant's days_from_civil).
    let (y, m) = if month <= 2 { (year - 1, month + 9) } else { (year, month - 3) };
    let era = y / 400;
    let year_of_era = y - era * 400;
    let day_of_year = (153 * m + 2) / 5 + day - 1;
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    let days = era * 146_097 + day_of_era - 719_468;
    Some(days * 86_400 + hour * 3_600 + minute * 60 + second)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retry_after_reads_seconds_and_dates() {
        assert_eq!(parse_retry_after(" 7 "), Some(Duration::from_secs(7)));
        assert_eq!(parse_http_date("Sun, 06 Nov 1994 08:49:37 GMT"), Some(784_111_777));
        assert_eq!(parse_http_date("Thu, 01 Jan 1970 00:00:00 GMT"), Some(0));
        // A year past IMF-fixdate's four digits is no date (it overflowed the day count).
        assert_eq!(parse_http_date("Sun, 06 Nov 999999999999 08:49:37 GMT"), None);
        assert!(parse_http_date("Fri, 31 Dec 9999 23:59:59 GMT").is_some());
        assert_eq!(parse_retry_after("Thu, 01 Jan 1970 00:00:00 GMT"), Some(Duration::ZERO), "a past date: retry now");
        for bad in ["soon", "-1", "Sun, 06 Nov 1994 08:49:37 CET", "Sun, 32 Nov 1994 08:49:37 GMT", ""] {
            assert_eq!(parse_retry_after(bad), None, "{bad}");
        }
    }

    #[test]
    fn waits_grow_with_jitter_and_honour_retry_after() {
        let policy = RetryPolicy { backoff: Duration::from_millis(100), max_wait: Duration::from_secs(10), ..RetryPolicy::default() };
        let io = ChatErrorKind::Io("reset".into());
        for attempts in 1..=4 {
            let full = Duration::from_millis(100) * 2u32.pow(attempts - 1);
            let wait = retry_wait(&io, attempts, &policy).unwrap();
            assert!(wait >= full / 2 && wait < full, "attempt {attempts}: {wait:?}");
        }
        let busy = |status, seconds| ChatErrorKind::Status { status, body: String::new(), retry_after: Some(Duration::from_secs(seconds)) };
        assert_eq!(retry_wait(&busy(429, 3), 1, &policy), Some(Duration::from_secs(3)));
        assert_eq!(retry_wait(&busy(503, 3), 2, &policy), Some(Duration::from_secs(3)));
        assert_eq!(retry_wait(&busy(429, 11), 1, &policy), None, "asks for more than max_wait");
        // Retry-After on a 500 is not a promise: backoff applies.
        assert!(retry_wait(&busy(500, 11), 1, &policy).unwrap() < Duration::from_millis(100));
    }

    #[test]
    fn urls_are_checked() {
        for good in ["http://127.0.0.1:8080/v1", "https://api.example.com/v1", "http://[::1]:9/x", "http://localhost"] {
            assert_eq!(check_url(good), Ok(()), "{good}");
        }
        for bad in
            ["ftp://a", "127.0.0.1:8080", "http://", "http://:80/v1", "http://a/v1?x=1", "http://a b", "http://a:99999/v1", "http://a:0"]
        {
            assert!(matches!(check_url(bad), Err(ChatErrorKind::BadUrl(_))), "{bad}");
        }
        // Credentials: refused, and named without them.
        let Err(ChatErrorKind::BadUrl(why)) = check_url("http://user:pw@h:8000/v1") else { panic!("credentials refused") };
        assert!(why.contains("…@h:8000") && !why.contains("pw"), "{why}");
        assert_eq!(redacted("http://user:pw@h:8000/v1/models"), "http://…@h:8000/v1/models");
        assert_eq!(redacted("https://h/v1"), "https://h/v1");
    }
}
