//! The HTTP side of `rhier view`: a `tiny_http` server (it parses requests and answers
//! a malformed one with 400 itself) whose requests a few worker threads take in turn
//! and answer with [`Viewer::handle`].

use std::sync::Arc;

use tiny_http::{Header, Response, Server};

use super::Viewer;

/// Worker threads: a frame being built does not hold up the page's other requests.
const WORKERS: usize = 4;

fn header(name: &str, value: &str) -> Option<Header> {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).ok()
}

/// Serves `viewer` on `server` until the process ends.
pub fn serve(viewer: Arc<Viewer>, server: Server) {
    let server = Arc::new(server);
    let workers: Vec<_> = (0..WORKERS)
        .map(|_| {
            let (server, viewer) = (server.clone(), viewer.clone());
            std::thread::spawn(move || {
                for request in server.incoming_requests() {
                    let reply = viewer.handle(request.method().as_str(), request.url());
                    let headers = [
                        header("Content-Type", reply.content_type),
                        header("Cache-Control", "no-store"),
                        header("X-Content-Type-Options", "nosniff"),
                    ];
                    let mut response =
                        Response::from_data(reply.body).with_status_code(reply.status);
                    for h in headers.into_iter().flatten() {
                        response.add_header(h);
                    }
                    // A client gone before its answer is not the server's failure.
                    let _ = request.respond(response);
                }
            })
        })
        .collect();
    for w in workers {
        let _ = w.join();
    }
}
