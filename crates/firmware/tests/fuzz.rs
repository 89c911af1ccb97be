//! The readers on arbitrary and mutated files: an error or a value, never
//! a panic.

use std::path::Path;

use parcal_firmware::klipper::parse_printer_cfg;
use parcal_firmware::probes::parse_probes;
use parcal_firmware::rrf::parse_config;
use proptest::prelude::*;

const CONFIG: &str = "M665 L270:270.2:269.9 R135 H300 B110 X0.1 Y-0.1 Z0\nM666 X0.1 Y0.2 Z-0.3 A0.01 B0.02\nG31 X0 Y-20 Z1.2\n";
const PRINTER_CFG: &str = "[printer]\nkinematics: delta\ndelta_radius: 135\n[stepper_a]\narm_length: 270\nposition_endstop: 300\n";
const PROBES: &str = "x,y,z\n0,0,0.01\n10,20,-0.02\n";

/// `text` with `byte` written at `at` (wrapped), as a lossy string.
fn mutated(text: &str, at: usize, byte: u8) -> String {
    let mut bytes = text.as_bytes().to_vec();
    let at = at % bytes.len();
    bytes[at] = byte;
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
        let path = Path::new("f");
        let _ = parse_config(&text, path);
        let _ = parse_printer_cfg(&text, path);
        let _ = parse_probes(text.as_bytes(), path);
    }

    #[test]
    fn mutated_files_never_panic(at in 0usize..1000, byte in any::<u8>()) {
        let path = Path::new("f");
        let _ = parse_config(&mutated(CONFIG, at, byte), path);
        let _ = parse_printer_cfg(&mutated(PRINTER_CFG, at, byte), path);
        let _ = parse_probes(mutated(PROBES, at, byte).as_bytes(), path);
    }
}
