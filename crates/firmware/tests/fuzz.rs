//! The readers on arbitrary and mutated files: an error or a value, never
//! a panic.

use std::path::Path;

use parcal_firmware::klipper::parse_printer;
use parcal_firmware::marlin;
use parcal_firmware::probes::parse_probes;
use parcal_firmware::rrf::parse_config;
use proptest::prelude::*;

const CONFIG: &str = "M665 L270:270.2:269.9 R135 H300 B110 X0.1 Y-0.1 Z0\nM666 X0.1 Y0.2 Z-0.3 A0.01 B0.02\nG31 X0 Y-20 Z1.2\n";
const PRINTER_CFG: &str = "[printer]\nkinematics: delta\ndelta_radius: 135\n[stepper_a]\narm_length: 270\nposition_endstop: 300\n\
    rotation_distance: 40\nmicrosteps: 16\n[stepper_b]\nstep_distance: 0.0125\n\
    [stepper_c]\nrotation_distance: 80\ngear_ratio: 2:1\nmicrosteps: 16\n\
    [delta_calibrate]\nheight0 = 0.7\nheight0_pos = 19000.5,19000.5,19000.5\n\
    distance0 = 100\ndistance0_pos1 = 19000,19100,19200\ndistance0_pos2 = 19200,19100,19000\n";
const M503: &str = "echo:  M665 L218.00 R97.50 H301.00 S200.00 X0.10 Y-0.10 Z0.00 A0.10 B0.00 C-0.10\necho:  M666 X-0.20 Y0.00 Z-0.10\necho:  M851 X0.00 Y-18.00 Z-0.75 ; (mm)\n";
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
        let _ = parse_printer(&text, path);
        let _ = marlin::parse_config(&text, path);
        let _ = parse_probes(text.as_bytes(), path);
    }

    #[test]
    fn mutated_files_never_panic(at in 0usize..1000, byte in any::<u8>()) {
        let path = Path::new("f");
        let _ = parse_config(&mutated(CONFIG, at, byte), path);
        let _ = parse_printer(&mutated(PRINTER_CFG, at, byte), path);
        let _ = marlin::parse_config(&mutated(M503, at, byte), path);
        let _ = parse_probes(mutated(PROBES, at, byte).as_bytes(), path);
    }
}

#[test]
fn the_files_mutated_are_read_whole() {
    let path = Path::new("f");
    assert!(parse_config(CONFIG, path).is_ok());
    assert!(marlin::parse_config(M503, path).is_ok());
    let printer = parse_printer(PRINTER_CFG, path).unwrap();
    assert_eq!(
        (printer.saved.probes.len(), printer.saved.distances.len()),
        (1, 1)
    );
    assert_eq!(parse_probes(PROBES.as_bytes(), path).unwrap().len(), 2);
}
