//! Rebuilds the crate when any file under assets/ is added, removed or
//! changed: rust-embed includes the files it finds at compile time, and a
//! new file alone would not otherwise trigger a rebuild.

fn main() {
    println!("cargo:rerun-if-changed=assets");
}
