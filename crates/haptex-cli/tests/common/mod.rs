//! What the CLI tests share: running the binary, writing an input file,
//! reading stderr. Each test binary uses its own part of it.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// A child process killed when the test ends, also when an assertion
/// fails before the test's own kill or wait.
pub struct KillOnDrop(pub std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Runs the haptex binary built for the tests.
pub fn haptex(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_haptex")).args(args).output().expect("run haptex")
}

/// Writes `text` to `dir/name` and returns the path as a string.
pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// The process's standard error as text, checked to follow the rule for
/// numbers shown to a person (`haptex_core::num`: no number of more than
/// 15 significant digits, no run of hundreds of digits): every test that
/// examines a message checks it.
#[track_caller]
pub fn stderr(out: &Output) -> String {
    let text = String::from_utf8_lossy(&out.stderr).into_owned();
    if let Some(number) = haptex_core::num::unreadable_number(&text) {
        panic!("an unreadable number ({number}) in the messages: {text}");
    }
    text
}

/// Reads a `haptex serve` child's standard error until it says where it
/// listens: the port, and everything it printed up to then.
/// The access token in the address `haptex serve` printed (in `seen`), if
/// it printed one.
pub fn printed_token(seen: &str) -> Option<String> {
    let line = seen.lines().find(|l| l.starts_with("open http://") || l.contains("open http://"))?;
    let token = line.split("?token=").nth(1)?;
    Some(token.split_whitespace().next()?.to_string())
}

pub fn listening_port(stderr: &mut impl std::io::BufRead) -> (u16, String) {
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        assert!(stderr.read_line(&mut line).unwrap() > 0, "haptex serve ended before listening: {seen}");
        seen.push_str(&line);
        if let Some(rest) = line.strip_prefix("open http://127.0.0.1:") {
            return (rest.split('/').next().unwrap().parse::<u16>().unwrap(), seen);
        }
    }
}
