//! HTTPS (issue 41, `haptex_server::tls`): certificates the test makes
//! (rcgen), the page and the API over TLS with the access token, the
//! cookie `Secure` and `Strict-Transport-Security` on every answer; plain
//! HTTP to the TLS port gets no answer; a certificate and key that do not
//! belong together, or files without them, are refused naming the files.

mod common;

use std::sync::Arc;
use std::time::Duration;

use haptex_server::access::{Access, Token};
use haptex_server::tls::{self, TlsError};
use haptex_server::{AppState, Limits};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const TOKEN: &str = "tls-test-token-0123456789";

/// A self-signed certificate for localhost and 127.0.0.1: (cert PEM, key PEM).
fn certificate() -> (String, String) {
    let made = rcgen::generate_simple_self_signed(vec!["localhost".to_string(), "127.0.0.1".to_string()]).unwrap();
    (made.cert.pem(), made.signing_key.serialize_pem())
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn certificates_and_keys_are_checked_before_serving() {
    let dir = tempfile::tempdir().unwrap();
    let (cert, key) = certificate();
    let (_, other_key) = certificate();
    let (cert, key, other_key) = (
        write(dir.path(), "cert.pem", &cert),
        write(dir.path(), "key.pem", &key),
        write(dir.path(), "other.pem", &other_key),
    );
    assert!(tls::acceptor(&cert, &key).is_ok());
    let e = tls::acceptor(&cert, &other_key).err().expect("a key of another certificate");
    assert!(matches!(e, TlsError::Pair { .. }), "{e}");
    assert!(e.to_string().contains("cert.pem") && e.to_string().contains("other.pem"), "{e}");
    let e = tls::acceptor(&key, &key).err().expect("a key given as the certificate");
    assert!(matches!(e, TlsError::Certificate { .. }) && e.to_string().contains("no certificate"), "{e}");
    let e = tls::acceptor(&cert, &cert).err().expect("a certificate given as the key");
    assert!(matches!(e, TlsError::Key { .. }) && e.to_string().contains("no private key"), "{e}");
    let missing = dir.path().join("missing.pem");
    let e = tls::acceptor(&missing, &key).err().expect("a missing file");
    assert!(e.to_string().starts_with("--tls-cert ") && e.to_string().contains("missing.pem"), "{e}");
}

/// Sends `request` over TLS (trusting `cert_pem` only) and reads the answer to its end.
async fn https(addr: std::net::SocketAddr, cert_pem: &str, request: impl AsRef<str>) -> String {
    let request = request.as_ref();
    use rustls::pki_types::pem::PemObject;
    let mut roots = rustls::RootCertStore::empty();
    roots.add(rustls::pki_types::CertificateDer::from_pem_slice(cert_pem.as_bytes()).unwrap()).unwrap();
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_root_certificates(roots)
        .with_no_client_auth();
    let connector = tokio_rustls::TlsConnector::from(Arc::new(config));
    let tcp = tokio::net::TcpStream::connect(addr).await.unwrap();
    let name = rustls::pki_types::ServerName::try_from("localhost").unwrap();
    let mut stream = connector.connect(name, tcp).await.unwrap();
    stream.write_all(request.as_bytes()).await.unwrap();
    let mut answer = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(10), stream.read_to_end(&mut answer)).await;
    String::from_utf8_lossy(&answer).into_owned()
}

#[tokio::test]
async fn the_page_and_the_api_over_https() {
    let dir = tempfile::tempdir().unwrap();
    let (cert_pem, key_pem) = certificate();
    let acceptor =
        tls::acceptor(&write(dir.path(), "cert.pem", &cert_pem), &write(dir.path(), "key.pem", &key_pem)).unwrap();
    let state = AppState::new(Some(&common::shipped_library()), Limits::DEFAULT)
        .unwrap()
        .with_database(&common::shipped_db())
        .unwrap()
        .with_access(Access::open().with_tls(true).with_token(Token::new(TOKEN).unwrap()).unwrap());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(haptex_server::serve_with(listener, state, Some(acceptor), async {
        let _ = stopped.await;
    }));

    let page = https(
        addr,
        &cert_pem,
        &format!("GET /?token={TOKEN} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"),
    )
    .await;
    assert!(page.starts_with("HTTP/1.1 200"), "{}", &page[..page.len().min(400)]);
    let head = page.split("\r\n\r\n").next().unwrap().to_ascii_lowercase();
    assert!(head.contains(&format!("strict-transport-security: {}", tls::HSTS)), "{head}");
    let cookie = head.lines().find_map(|l| l.strip_prefix("set-cookie: ")).expect("a session cookie").to_string();
    assert!(cookie.ends_with("; secure"), "{cookie}");
    assert!(page.contains("<title>"));

    let health = https(
        addr,
        &cert_pem,
        &format!(
            "GET /api/health HTTP/1.1\r\nHost: localhost\r\nAuthorization: Bearer {TOKEN}\r\nConnection: close\r\n\r\n"
        ),
    )
    .await;
    assert!(health.starts_with("HTTP/1.1 200") && health.contains("\"templates\":true"), "{health}");
    // A prediction, from the page's own origin (https), with the cookie.
    let body = r#"{"surface":"bump","x0_mm":5,"width_mm":1.3,"height_mm":0.27,"velocity_mm_s":20}"#;
    let cookie_pair = cookie.split(';').next().unwrap();
    let predict_from = |origin: &str| {
        https(
            addr,
            &cert_pem,
            format!(
                "POST /api/predict HTTP/1.1\r\nHost: localhost\r\nOrigin: {origin}\r\nCookie: {cookie_pair}\r\n\
                 Content-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                body.len()
            ),
        )
    };
    let predict = predict_from("https://localhost").await;
    assert!(
        predict.starts_with("HTTP/1.1 200") && predict.contains("\"x_mm\""),
        "{}",
        &predict[..predict.len().min(400)]
    );
    // The same request from the http:// origin of the same host is another origin.
    let foreign = predict_from("http://localhost").await;
    assert!(foreign.starts_with("HTTP/1.1 403") && foreign.contains("\"field\":\"origin\""), "{foreign}");

    // Plain HTTP to the TLS port: no HTTP answer (the handshake fails).
    let mut plain = tokio::net::TcpStream::connect(addr).await.unwrap();
    plain.write_all(b"GET /api/health HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").await.unwrap();
    let mut answer = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(10), plain.read_to_end(&mut answer)).await;
    assert!(!answer.starts_with(b"HTTP/1.1 200"), "{}", String::from_utf8_lossy(&answer));

    stop.send(()).unwrap();
    tokio::time::timeout(Duration::from_secs(15), server).await.unwrap().unwrap().unwrap();
}
