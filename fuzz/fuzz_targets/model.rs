//! Fuzzes the model-file reader: any text must give a model or an error, never a panic, and a
//! model read must write back to JSON that reads again.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tolles::model::ModelFile;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(model) = ModelFile::from_json(text, "fuzz.json") {
        let again = model.to_json();
        ModelFile::from_json(&again, "again.json").expect("a model written reads back");
    }
});
