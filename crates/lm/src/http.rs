//! A minimal HTTP/1.1 client: one JSON POST per connection (`Connection: close`) over
//! `std::net::TcpStream`, with one deadline covering connect, write and read. Hand-rolled on
//! purpose: the model servers it talks to (vLLM, llama.cpp server, Ollama) sit on loopback or a
//! local network over plain HTTP, and the HTTP crates that would do this pull a URL/IDNA stack
//! and a TLS stack into every build of the planner. It reads `Content-Length`, chunked and
//! read-to-close bodies, and reports every failure as an [`HttpErrorKind`].

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use crate::error::HttpErrorKind;

/// Largest response body accepted (a completions answer is a few kilobytes).
const MAX_RESPONSE_BYTES: usize = 64 << 20;

/// `http://host[:port][/prefix]`, split.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Url {
    pub host: String,
    pub port: u16,
    /// The path before the endpoint, without a trailing slash (`/v1` or empty).
    pub prefix: String,
}

impl Url {
    pub(crate) fn parse(url: &str) -> Result<Url, HttpErrorKind> {
        let bad = |why: &str| HttpErrorKind::BadUrl(format!("`{url}`: {why}"));
        let rest = if let Some(rest) = url.strip_prefix("http://") {
            rest
        } else if url.starts_with("https://") {
            return Err(bad("https is not supported (no TLS stack is built in); use http:// or a local TLS-terminating proxy"));
        } else {
            return Err(bad("expected http://host[:port][/path]"));
        };
        let (authority, path) = match rest.find('/') {
            Some(i) => (&rest[..i], &rest[i..]),
            None => (rest, ""),
        };
        let (host, port) = if let Some(bracketed) = authority.strip_prefix('[') {
            let (host, after) = bracketed.split_once(']').ok_or_else(|| bad("unclosed `[` in the host"))?;
            let port = match after.strip_prefix(':') {
                Some(p) => p.parse().map_err(|_| bad("bad port"))?,
                None if after.is_empty() => 80,
                None => return Err(bad("bad port")),
            };
            (host.to_string(), port)
        } else {
            match authority.rsplit_once(':') {
                Some((host, port)) => (host.to_string(), port.parse().map_err(|_| bad("bad port"))?),
                None => (authority.to_string(), 80),
            }
        };
        if host.is_empty() {
            return Err(bad("no host"));
        }
        if path.contains(['?', '#', ' ']) {
            return Err(bad("a query or fragment in a base URL"));
        }
        Ok(Url { host, port, prefix: path.trim_end_matches('/').to_string() })
    }

    fn authority(&self) -> String {
        if self.host.contains(':') { format!("[{}]:{}", self.host, self.port) } else { format!("{}:{}", self.host, self.port) }
    }
}

/// Status and body of an answer.
#[derive(Debug, Clone)]
pub(crate) struct Response {
    pub status: u16,
    pub body: Vec<u8>,
}

fn io_error(error: &std::io::Error, timeout: Duration) -> HttpErrorKind {
    match error.kind() {
        ErrorKind::TimedOut | ErrorKind::WouldBlock => HttpErrorKind::Timeout(timeout),
        _ => HttpErrorKind::Io(error.to_string()),
    }
}

fn remaining(deadline: Instant, timeout: Duration) -> Result<Duration, HttpErrorKind> {
    let left = deadline.saturating_duration_since(Instant::now());
    if left.is_zero() { Err(HttpErrorKind::Timeout(timeout)) } else { Ok(left) }
}

/// POSTs `body` as JSON to `url.prefix + path` and returns the answer, whatever its status.
pub(crate) fn post_json(url: &Url, path: &str, body: &[u8], bearer: Option<&str>, timeout: Duration) -> Result<Response, HttpErrorKind> {
    let deadline = Instant::now() + timeout;
    let addresses: Vec<SocketAddr> =
        (url.host.as_str(), url.port).to_socket_addrs().map_err(|e| HttpErrorKind::Connect(format!("{}: {e}", url.authority())))?.collect();
    let mut stream = None;
    let mut last_error = String::from("no address");
    for address in addresses {
        match TcpStream::connect_timeout(&address, remaining(deadline, timeout)?) {
            Ok(s) => {
                stream = Some(s);
                break;
            }
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock) => return Err(HttpErrorKind::Timeout(timeout)),
            Err(e) => last_error = format!("{address}: {e}"),
        }
    }
    let mut stream = stream.ok_or(HttpErrorKind::Connect(last_error))?;
    stream.set_nodelay(true).ok();

    let mut request = format!(
        "POST {}{} HTTP/1.1\r\nHost: {}\r\nContent-Type: application/json\r\nAccept: application/json\r\nContent-Length: {}\r\nConnection: close\r\n",
        url.prefix,
        path,
        url.authority(),
        body.len()
    );
    if let Some(token) = bearer {
        request.push_str(&format!("Authorization: Bearer {token}\r\n"));
    }
    request.push_str("\r\n");
    stream.set_write_timeout(Some(remaining(deadline, timeout)?)).map_err(|e| io_error(&e, timeout))?;
    stream.write_all(request.as_bytes()).and_then(|_| stream.write_all(body)).map_err(|e| io_error(&e, timeout))?;

    let mut buffer = Vec::with_capacity(8192);
    let mut chunk = [0u8; 8192];
    let mut head: Option<(u16, Framing, usize)> = None;
    loop {
        if let Some((status, framing, body_start)) = head {
            let body = &buffer[body_start..];
            match framing {
                Framing::Length(n) if body.len() >= n => return Ok(Response { status, body: body[..n].to_vec() }),
                Framing::Chunked => {
                    if let Some(decoded) = decode_chunked(body)? {
                        return Ok(Response { status, body: decoded });
                    }
                }
                _ => {}
            }
        }
        stream.set_read_timeout(Some(remaining(deadline, timeout)?)).map_err(|e| io_error(&e, timeout))?;
        let read = match stream.read(&mut chunk) {
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(io_error(&e, timeout)),
        };
        if read == 0 {
            return match head {
                Some((status, Framing::UntilClose, body_start)) => Ok(Response { status, body: buffer[body_start..].to_vec() }),
                Some((_, Framing::Length(n), body_start)) => {
                    Err(HttpErrorKind::Io(format!("connection closed after {} of {n} body bytes", buffer.len() - body_start)))
                }
                Some((_, Framing::Chunked, _)) => Err(HttpErrorKind::Io("connection closed inside a chunked body".into())),
                None if buffer.is_empty() => Err(HttpErrorKind::Io("connection closed before any response".into())),
                None => Err(HttpErrorKind::MalformedHttp("connection closed inside the response headers".into())),
            };
        }
        buffer.extend_from_slice(&chunk[..read]);
        if buffer.len() > MAX_RESPONSE_BYTES {
            return Err(HttpErrorKind::MalformedHttp(format!("response larger than {MAX_RESPONSE_BYTES} bytes")));
        }
        if head.is_none()
            && let Some(end) = find(&buffer, b"\r\n\r\n")
        {
            let (status, framing) = parse_head(&buffer[..end])?;
            head = Some((status, framing, end + 4));
        } else if head.is_none() && buffer.len() > 64 * 1024 {
            return Err(HttpErrorKind::MalformedHttp("no end of headers in the first 64 KiB".into()));
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Framing {
    Length(usize),
    Chunked,
    UntilClose,
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn parse_head(head: &[u8]) -> Result<(u16, Framing), HttpErrorKind> {
    let text = std::str::from_utf8(head).map_err(|_| HttpErrorKind::MalformedHttp("headers are not UTF-8".into()))?;
    let mut lines = text.split("\r\n");
    let status_line = lines.next().unwrap_or_default();
    let mut parts = status_line.splitn(3, ' ');
    let version = parts.next().unwrap_or_default();
    if !version.starts_with("HTTP/1.") {
        return Err(HttpErrorKind::MalformedHttp(format!("status line `{}`", status_line.chars().take(80).collect::<String>())));
    }
    let status: u16 = parts
        .next()
        .and_then(|s| s.parse().ok())
        .filter(|s| (100..600).contains(s))
        .ok_or_else(|| HttpErrorKind::MalformedHttp(format!("status line `{}`", status_line.chars().take(80).collect::<String>())))?;
    let mut framing = Framing::UntilClose;
    for line in lines {
        let Some((name, value)) = line.split_once(':') else {
            return Err(HttpErrorKind::MalformedHttp(format!("header line `{}`", line.chars().take(80).collect::<String>())));
        };
        let value = value.trim();
        if name.eq_ignore_ascii_case("transfer-encoding") && value.to_ascii_lowercase().contains("chunked") {
            framing = Framing::Chunked;
        } else if name.eq_ignore_ascii_case("content-length") && framing != Framing::Chunked {
            let n = value.parse().map_err(|_| HttpErrorKind::MalformedHttp(format!("Content-Length `{value}`")))?;
            framing = Framing::Length(n);
        }
    }
    Ok((status, framing))
}

/// The body of a complete chunked encoding, `None` while more bytes are needed.
fn decode_chunked(mut data: &[u8]) -> Result<Option<Vec<u8>>, HttpErrorKind> {
    let mut out = Vec::new();
    loop {
        let Some(line_end) = find(data, b"\r\n") else { return Ok(None) };
        let line = std::str::from_utf8(&data[..line_end]).map_err(|_| HttpErrorKind::MalformedHttp("chunk size is not text".into()))?;
        let size_text = line.split(';').next().unwrap_or_default().trim();
        let size = usize::from_str_radix(size_text, 16).map_err(|_| HttpErrorKind::MalformedHttp(format!("chunk size `{size_text}`")))?;
        data = &data[line_end + 2..];
        if size == 0 {
            // Trailers, if any, end with an empty line; a bare CRLF is the common case.
            return Ok(if data.starts_with(b"\r\n") || find(data, b"\r\n\r\n").is_some() { Some(out) } else { None });
        }
        if data.len() < size + 2 {
            return Ok(None);
        }
        out.extend_from_slice(&data[..size]);
        if &data[size..size + 2] != b"\r\n" {
            return Err(HttpErrorKind::MalformedHttp("chunk not followed by CRLF".into()));
        }
        data = &data[size + 2..];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_split_into_host_port_and_prefix() {
        assert_eq!(Url::parse("http://127.0.0.1:8000/v1/").unwrap(), Url { host: "127.0.0.1".into(), port: 8000, prefix: "/v1".into() });
        assert_eq!(Url::parse("http://localhost").unwrap(), Url { host: "localhost".into(), port: 80, prefix: String::new() });
        assert_eq!(Url::parse("http://[::1]:9/x").unwrap(), Url { host: "::1".into(), port: 9, prefix: "/x".into() });
        for bad in ["https://a", "ftp://a", "http://:80", "http://a:port", "http://a/?q=1"] {
            assert!(matches!(Url::parse(bad), Err(HttpErrorKind::BadUrl(_))), "{bad}");
        }
    }

    #[test]
    fn heads_give_status_and_framing() {
        assert_eq!(parse_head(b"HTTP/1.1 200 OK\r\nContent-Length: 12").unwrap(), (200, Framing::Length(12)));
        assert_eq!(parse_head(b"HTTP/1.1 500 Oops\r\ntransfer-encoding: chunked").unwrap(), (500, Framing::Chunked));
        assert_eq!(parse_head(b"HTTP/1.0 204 No Content").unwrap(), (204, Framing::UntilClose));
        assert!(parse_head(b"SSH-2.0-OpenSSH").is_err());
        assert!(parse_head(b"HTTP/1.1 abc").is_err());
        assert!(parse_head(b"HTTP/1.1 200 OK\r\nContent-Length: -1").is_err());
    }

    #[test]
    fn chunked_bodies_decode_only_when_complete() {
        let full = b"4\r\nWiki\r\n5;ext=1\r\npedia\r\n0\r\n\r\n";
        assert_eq!(decode_chunked(full).unwrap(), Some(b"Wikipedia".to_vec()));
        for cut in 0..full.len() - 1 {
            assert_eq!(decode_chunked(&full[..cut]).unwrap(), None, "cut at {cut}");
        }
        assert!(decode_chunked(b"zz\r\n").is_err());
        assert!(decode_chunked(b"2\r\nabX\r\n").is_err());
    }
}
