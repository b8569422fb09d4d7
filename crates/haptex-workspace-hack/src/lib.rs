//! Build-time only: see this crate's Cargo.toml. It has no code; haptex-py
//! depends on it for the features it switches on in shared dependencies.
