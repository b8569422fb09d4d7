#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| haptex_fuzz::library_names(data));
