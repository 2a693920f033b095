//! Which proxy a request goes through, read from the environment as curl and Python's
//! `requests` read it: `http_proxy`/`HTTP_PROXY` for `http://` URLs, `https_proxy`/
//! `HTTPS_PROXY` for `https://` ones, `all_proxy`/`ALL_PROXY` for either where those are unset
//! (lower case first; empty is unset), none for a host `no_proxy`/`NO_PROXY` lists (`*`, a host
//! name or domain, with or without a leading dot, an IP address, or an IP range in CIDR
//! notation, `127.0.0.0/8`).
//!
//! Written here rather than left to `ureq`'s `Proxy::try_from_env`, which takes the first of
//! `ALL_PROXY`, `HTTPS_PROXY` and `HTTP_PROXY` for every scheme (a site's HTTPS proxy then
//! carried the requests to a model server on a plain-HTTP local address) and reads no CIDR
//! range in `NO_PROXY`.

use std::net::IpAddr;

use crate::error::ChatErrorKind;

/// The proxy a URL's requests go through, and the variable that named it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProxyChoice {
    /// The environment variable (`https_proxy`, `HTTP_PROXY`, ...).
    pub variable: &'static str,
    /// Its value, with `http://` in front where it named no scheme.
    pub url: String,
}

/// The proxy for `url` from the process's environment; `None` for a direct connection.
pub fn proxy_for(url: &str) -> Option<ProxyChoice> {
    choose(url, |name| std::env::var(name).ok())
}

/// The proxy for `url` with the variables `env` gives (see the module docs).
pub fn choose(url: &str, env: impl Fn(&str) -> Option<String>) -> Option<ProxyChoice> {
    let set = |name: &str| env(name).map(|v| v.trim().to_string()).filter(|v| !v.is_empty());
    let (scheme, rest) = url.split_once("://")?;
    let authority = rest.split('/').next().unwrap_or_default();
    let host = host_of(authority.rsplit('@').next().unwrap_or(authority));
    let bypass = set("no_proxy").or_else(|| set("NO_PROXY")).is_some_and(|list| list.split(',').any(|entry| bypassed(&host, entry)));
    if bypass {
        return None;
    }
    let names: [&'static str; 4] = match scheme.to_ascii_lowercase().as_str() {
        "https" => ["https_proxy", "HTTPS_PROXY", "all_proxy", "ALL_PROXY"],
        _ => ["http_proxy", "HTTP_PROXY", "all_proxy", "ALL_PROXY"],
    };
    names.into_iter().find_map(|variable| {
        set(variable).map(|value| ProxyChoice { variable, url: if value.contains("://") { value } else { format!("http://{value}") } })
    })
}

/// The host of an authority (`host:port`, `[v6]:port`), lower case, without brackets.
fn host_of(authority: &str) -> String {
    let host = match authority.strip_prefix('[') {
        Some(rest) => rest.split(']').next().unwrap_or_default(),
        None => authority.rsplit_once(':').map_or(authority, |(host, _)| host),
    };
    host.to_ascii_lowercase()
}

/// Whether one `NO_PROXY` entry covers `host`.
fn bypassed(host: &str, entry: &str) -> bool {
    let entry = entry.trim().to_ascii_lowercase();
    if entry.is_empty() {
        return false;
    }
    if entry == "*" {
        return true;
    }
    if let (Some((network, bits)), Ok(address)) = (entry.split_once('/'), host.parse::<IpAddr>()) {
        return match (network.parse::<IpAddr>(), bits.parse::<u32>()) {
            (Ok(network), Ok(bits)) => in_range(address, network, bits),
            _ => false,
        };
    }
    // A port on the entry is not compared (as curl before 8.x, and `requests`).
    let name = if !entry.starts_with('[') && entry.matches(':').count() > 1 { entry.clone() } else { host_of(&entry) };
    let name = name.trim_start_matches("*.").trim_start_matches('.');
    if let (Ok(a), Ok(b)) = (host.parse::<IpAddr>(), name.parse::<IpAddr>()) {
        return a == b;
    }
    host == name || host.strip_suffix(name).is_some_and(|head| head.ends_with('.'))
}

/// Whether `address` lies in `network/bits`.
fn in_range(address: IpAddr, network: IpAddr, bits: u32) -> bool {
    match (address, network) {
        (IpAddr::V4(a), IpAddr::V4(n)) if bits <= 32 => {
            let mask = if bits == 0 { 0 } else { u32::MAX << (32 - bits) };
            u32::from(a) & mask == u32::from(n) & mask
        }
        (IpAddr::V6(a), IpAddr::V6(n)) if bits <= 128 => {
            let mask = if bits == 0 { 0 } else { u128::MAX << (128 - bits) };
            u128::from(a) & mask == u128::from(n) & mask
        }
        _ => false,
    }
}

/// A `ureq` proxy for `choice`; a value that is not a proxy URL is a bad URL naming the
/// variable (its credentials, if any, not printed).
pub(crate) fn ureq_proxy(choice: &ProxyChoice) -> Result<ureq::Proxy, ChatErrorKind> {
    ureq::Proxy::new(&choice.url).map_err(|e| {
        ChatErrorKind::BadUrl(format!(
            "{}={}: not a proxy this client can use ({e})",
            choice.variable,
            crate::transport::redacted(&choice.url)
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| vars.iter().find(|(n, _)| *n == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn each_scheme_takes_its_own_variable_then_all_proxy() {
        let vars = [("HTTPS_PROXY", "http://corp:3128"), ("ALL_PROXY", "http://all:1")];
        assert_eq!(choose("https://api.example.com/v1", with(&vars)).map(|c| c.variable), Some("HTTPS_PROXY"));
        // A plain-HTTP server does not go through the HTTPS proxy (ureq sent it there).
        assert_eq!(choose("http://10.0.0.5:8000/v1", with(&vars)).map(|c| c.variable), Some("ALL_PROXY"));
        assert_eq!(choose("http://10.0.0.5:8000/v1", with(&[("HTTPS_PROXY", "http://corp:3128")])), None);
        let lower = [("http_proxy", "proxy.lan:8080"), ("HTTP_PROXY", "http://upper:1")];
        assert_eq!(
            choose("http://h/v1", with(&lower)),
            Some(ProxyChoice { variable: "http_proxy", url: "http://proxy.lan:8080".into() }),
            "lower case first; no scheme means http://"
        );
        assert_eq!(
            choose("http://h/v1", with(&[("http_proxy", " "), ("HTTP_PROXY", "http://upper:1")])).map(|c| c.variable),
            Some("HTTP_PROXY")
        );
    }

    #[test]
    fn no_proxy_takes_names_domains_addresses_and_ranges() {
        let proxy = ("HTTP_PROXY", "http://corp:3128");
        for (list, url, direct) in [
            ("*", "http://anything/v1", true),
            ("localhost,127.0.0.1", "http://127.0.0.1:8000/v1", true),
            ("127.0.0.0/8", "http://127.0.0.1:8000/v1", true),
            ("10.0.0.0/8", "http://127.0.0.1:8000/v1", false),
            ("::1", "http://[::1]:8000/v1", true),
            ("fd00::/8", "http://[fd12::1]:8000/v1", true),
            (".example.com", "http://gpu.example.com:8000/v1", true),
            ("example.com", "http://gpu.example.com/v1", true),
            ("example.com", "http://badexample.com/v1", false),
            ("*.example.com", "http://example.com/v1", true),
            ("gpu:8000", "http://gpu:9000/v1", true),
            ("!!!,,,", "http://gpu/v1", false),
            ("300.1.1.1/8", "http://300.1.1.1/v1", false),
        ] {
            let vars = [proxy, ("NO_PROXY", list)];
            assert_eq!(choose(url, with(&vars)).is_none(), direct, "{list} {url}");
        }
    }

    #[test]
    fn a_value_that_is_no_proxy_url_names_its_variable() {
        let choice = ProxyChoice { variable: "HTTP_PROXY", url: "http://user:pw@::::".into() };
        let Err(ChatErrorKind::BadUrl(why)) = ureq_proxy(&choice) else { panic!("refused") };
        assert!(why.starts_with("HTTP_PROXY=http://…@") && !why.contains("pw"), "{why}");
    }
}
