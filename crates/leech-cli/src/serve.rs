//! `leech serve`: starts the console (`leech_console`) and its web server,
//! prints the URL to open, and serves until interrupted.
//!
//! Exit codes: a port that cannot be opened is bad input (2), as is an
//! address taken or not allowed; anything else that stops the console is 1.

use std::io::Write as _;
use std::sync::Arc;

use leech_console::console::StartError;
use leech_console::server;
use leech_console::Console;
use leech_link::host::LinkError;

use crate::args::serve::DEFAULT_LISTEN;
use crate::args::Serve;
use crate::failure::Failure;

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
        let query = a.token.as_deref().map_or(String::new(), |t| format!("?token={t}"));
        let mut stdout = std::io::stdout();
        let _ = writeln!(stdout, "leech console: open http://{addr}/{query} (Ctrl-C stops)").and_then(|()| stdout.flush());
        tokio::select! {
            served = server::serve(Arc::new(console), listener, a.token) => served.map_err(|e| Failure::Other(e.into())),
            _ = tokio::signal::ctrl_c() => Ok(()),
        }
    })
}
