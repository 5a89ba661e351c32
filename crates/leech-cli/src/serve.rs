//! `leech serve`: starts the console (`leech_console`) and its web server,
//! prints the URL to open, and serves until interrupted.
//!
//! Exit codes: a port that cannot be opened is bad input (2), as is an
//! address taken or not allowed; anything else that stops the console is 1.

use std::io::Write as _;
use std::net::SocketAddr;
use std::sync::Arc;

use leech_console::console::StartError;
use leech_console::server;
use leech_console::Console;
use leech_link::host::LinkError;

use crate::args::serve::DEFAULT_LISTEN;
use crate::args::Serve;
use crate::failure::Failure;

/// The line that says where the console is: the address as given, or,
/// listening on every interface, this machine's address `here` (another
/// machine cannot open `http://0.0.0.0:...`).
fn where_to_open(addr: SocketAddr, token: Option<&str>, here: Option<&str>) -> String {
    let query = token.map_or(String::new(), |t| format!("?token={t}"));
    if addr.ip().is_unspecified() {
        let port = addr.port();
        let there = here.map_or(format!("http://<this machine's address>:{port}/{query}"), |h| {
            let h = if h.contains(':') && !h.starts_with('[') { format!("[{h}]") } else { h.to_string() };
            format!("http://{h}:{port}/{query}")
        });
        format!(
            "leech console: listening on every interface ({addr}): open {there} from another machine, \
             http://127.0.0.1:{port}/{query} on this one (Ctrl-C stops)"
        )
    } else {
        format!("leech console: open http://{addr}/{query} (Ctrl-C stops)")
    }
}

/// This machine's address on the network it would reach others by (a UDP
/// socket "connected" to a documentation address: nothing is sent), or its
/// name.
fn this_machine(addr: SocketAddr) -> Option<String> {
    let (any, probe) = if addr.is_ipv4() { ("0.0.0.0:0", "192.0.2.1:9") } else { ("[::]:0", "[2001:db8::1]:9") };
    let routed = std::net::UdpSocket::bind(any)
        .and_then(|s| s.connect(probe).and_then(|()| s.local_addr()))
        .ok()
        .map(|a| a.ip())
        .filter(|ip| !ip.is_unspecified() && !ip.is_loopback());
    routed.map(|ip| ip.to_string()).or_else(|| {
        let name = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::fs::read_to_string("/etc/hostname"))
            .ok()?;
        Some(name.trim().to_string()).filter(|n| !n.is_empty())
    })
}

pub fn serve(a: Serve) -> Result<(), Failure> {
    let runtime = tokio::runtime::Runtime::new().map_err(|e| Failure::Other(e.into()))?;
    let console = Console::start(a.setup).map_err(|e| match e {
        StartError::Link(e @ LinkError::Open { .. }) => Failure::Input(format!("--port: {e}")),
        other => Failure::Other(other.into()),
    })?;
    runtime.block_on(async move {
        let listener = match a.listen {
            Some(addr) => tokio::net::TcpListener::bind(addr)
                .await
                .map_err(|e| Failure::Input(format!("--listen {addr}: cannot listen there: {e}")))?,
            // The default port may be taken (another console): any free one then.
            None => match tokio::net::TcpListener::bind(DEFAULT_LISTEN).await {
                Ok(l) => l,
                Err(_) => tokio::net::TcpListener::bind("127.0.0.1:0").await.map_err(|e| Failure::Other(e.into()))?,
            },
        };
        let addr = listener.local_addr().map_err(|e| Failure::Other(e.into()))?;
        let here = if addr.ip().is_unspecified() { this_machine(addr) } else { None };
        let mut stdout = std::io::stdout();
        let _ = writeln!(stdout, "{}", where_to_open(addr, a.token.as_deref(), here.as_deref())).and_then(|()| stdout.flush());
        tokio::select! {
            served = server::serve(Arc::new(console), listener, a.token) => served.map_err(|e| Failure::Other(e.into())),
            _ = tokio::signal::ctrl_c() => Ok(()),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_url_printed_opens_from_where_it_says() {
        let local: SocketAddr = "127.0.0.1:8080".parse().unwrap();
        assert_eq!(where_to_open(local, None, None), "leech console: open http://127.0.0.1:8080/ (Ctrl-C stops)");
        let any: SocketAddr = "0.0.0.0:8080".parse().unwrap();
        let line = where_to_open(any, Some("secret-token"), Some("192.168.1.7"));
        assert!(line.contains("every interface"), "{line}");
        assert!(line.contains("open http://192.168.1.7:8080/?token=secret-token from another machine"), "{line}");
        assert!(!line.contains("http://0.0.0.0"), "{line}");
        let any6: SocketAddr = "[::]:8080".parse().unwrap();
        assert!(where_to_open(any6, Some("secret-token"), Some("fe80::1")).contains("http://[fe80::1]:8080/"));
        assert!(where_to_open(any, Some("secret-token"), None).contains("http://<this machine's address>:8080/"));
    }
}
