//! Arbitrary text as a colour file, in Player's format and in TOML: an error (with a line
//! and column inside the text) or a configuration CMVision accepts, never a panic.
#![no_main]

use lewis_perception::cmvision::{CmVision, ColorConfig, ColorFileError, RgbFrame};
use libfuzzer_sys::fuzz_target;

fn check(parsed: Result<ColorConfig, ColorFileError>, text: &str) {
    match parsed {
        Ok(config) => {
            // A file that parses segments a frame of every colour it names.
            let Ok(mut cmvision) = CmVision::new(&config) else {
                return;
            };
            let pixels: Vec<u8> = config.colors.iter().flat_map(|c| c.display_rgb).collect();
            if let Ok(frame) = RgbFrame::new(u32::try_from(config.colors.len()).unwrap_or(1), 1, &pixels) {
                let regions = cmvision.process(frame);
                assert!(regions.iter().all(|r| r.area_px >= 1));
            }
        }
        Err(ColorFileError::Invalid { line, column, .. }) => {
            // The end of a text that ends with a newline is the start of the line after
            // it: an error there (an unexpected end of file) names that line.
            let lines = text.split('\n').count();
            assert!(line >= 1 && line <= lines, "line {line} of {lines}");
            assert!(column >= 1);
        }
        Err(ColorFileError::Read { .. }) => unreachable!("no file is read"),
    }
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    check(ColorConfig::from_player_str(&text, "fuzz.txt"), &text);
    check(ColorConfig::from_toml_str(&text, "fuzz.toml"), &text);
});
