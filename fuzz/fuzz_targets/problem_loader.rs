//! Any bytes as a problem file, through everything `omcbsa plan` does before planning:
//! decoding, parsing, and every check of the loader. It must return, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use omcbsa::load;
use omcbsa_core::model::KinovaGen3;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = load::decode_text(data.to_vec()) else {
        return;
    };
    let Ok(file) = load::parse_problem(&text) else {
        return;
    };
    if load::model_of(&file).is_ok() {
        let _ = load::problem::<KinovaGen3, 7>(&file);
    }
});
