//! Klipper's `SAVE_CONFIG` block: the `#*#` lines that end a `printer.cfg`,
//! sections of `key = value` options (a value may go on over indented
//! lines, a bed mesh's points), which override the main part. A block is
//! read with every section and option it holds, options are set in place
//! or added, and it is written back as Klipper's `SAVE_CONFIG` writes it.

/// The line that opens the block.
pub(super) const MARKER: &str = "#*# <---------------------- SAVE_CONFIG ---------------------->";
/// The notice on the block's second line.
pub(super) const NOTICE: &str = "DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.";
/// The prefix of every line of the block.
pub(super) const PREFIX: &str = "#*#";

/// Whether `line` opens the block.
pub(super) fn is_marker(line: &str) -> bool {
    line.trim_end() == MARKER
}

/// A `SAVE_CONFIG` block (module doc).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct SaveConfig {
    sections: Vec<Section>,
}

/// A section of the block: its name and options in order.
#[derive(Debug, Clone, PartialEq)]
struct Section {
    name: String,
    options: Vec<SavedOption>,
}

/// An option: its key (lower case, as Klipper reads it) and its lines
/// (`key = value`, then any continuation lines), without the prefix.
#[derive(Debug, Clone, PartialEq)]
struct SavedOption {
    key: String,
    lines: Vec<String>,
}

impl SaveConfig {
    /// `printer_cfg` split at its block: the text before it and the block
    /// (empty without one). The block's lines that are not `#*#` lines, or
    /// come before its first section, are not Klipper's and are dropped,
    /// as Klipper's reader ignores them.
    pub(super) fn split(printer_cfg: &str) -> (&str, Self) {
        let mut offset = 0;
        let mut start = None;
        for line in printer_cfg.split_inclusive('\n') {
            if is_marker(line) {
                start = Some(offset);
                break;
            }
            offset += line.len();
        }
        let Some(start) = start else {
            return (printer_cfg, Self::default());
        };
        let mut block = Self::default();
        for line in printer_cfg[start..].lines().skip(1) {
            let Some(rest) = line.strip_prefix(PREFIX) else {
                continue;
            };
            let rest = rest.strip_prefix(' ').unwrap_or(rest);
            if rest == NOTICE || rest.trim().is_empty() {
                continue;
            }
            let header = rest.trim();
            if let Some(name) = header.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
                block.sections.push(Section {
                    name: name.trim().to_string(),
                    options: Vec::new(),
                });
                continue;
            }
            let Some(section) = block.sections.last_mut() else {
                continue;
            };
            match section.options.last_mut() {
                Some(option) if rest.starts_with([' ', '\t']) => {
                    option.lines.push(rest.to_string());
                }
                _ => {
                    let key = rest.split([':', '=']).next().unwrap_or(rest);
                    section.options.push(SavedOption {
                        key: key.trim().to_lowercase(),
                        lines: vec![rest.to_string()],
                    });
                }
            }
        }
        (&printer_cfg[..start], block)
    }

    /// Sets `key = value` in `section` (its line replacing the option's
    /// lines), the section and the option added at the end if absent.
    pub(super) fn set(&mut self, section: &str, key: &str, value: &str) {
        let index = match self.sections.iter().position(|s| s.name == section) {
            Some(index) => index,
            None => {
                self.sections.push(Section {
                    name: section.to_string(),
                    options: Vec::new(),
                });
                self.sections.len() - 1
            }
        };
        let options = &mut self.sections[index].options;
        let lines = vec![format!("{key} = {value}")];
        match options.iter_mut().find(|o| o.key == key) {
            Some(option) => option.lines = lines,
            None => options.push(SavedOption {
                key: key.to_string(),
                lines,
            }),
        }
    }

    /// The block's text, as Klipper writes it: the marker, the notice,
    /// then each section after a `#*#` line.
    pub(super) fn render(&self) -> String {
        let mut text = format!("{MARKER}\n{PREFIX} {NOTICE}\n");
        for section in &self.sections {
            text.push_str(&format!("{PREFIX}\n{PREFIX} [{}]\n", section.name));
            for line in section.options.iter().flat_map(|o| &o.lines) {
                text.push_str(&format!("{PREFIX} {line}\n"));
            }
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block as Klipper writes it: a probe's offset, a bed mesh whose
    /// points go on over indented lines, the delta and its calibration's
    /// probes.
    const BLOCK: &str = "#*# <---------------------- SAVE_CONFIG ---------------------->
#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.
#*#
#*# [probe]
#*# z_offset = 0.650
#*#
#*# [bed_mesh default]
#*# version = 1
#*# points =
#*# \t-0.012500, 0.025000
#*# \t0.037500, -0.005000
#*# x_count = 2
#*#
#*# [printer]
#*# delta_radius = 134.500000
#*#
#*# [delta_calibrate]
#*# height0 = 0.65
#*# height0_pos = 19000.000,19000.000,19000.000
";

    #[test]
    fn a_block_is_read_and_written_back_as_it_was() {
        let text = format!("[printer]\nkinematics: delta\n\n{BLOCK}");
        let (main, block) = SaveConfig::split(&text);
        assert_eq!(main, "[printer]\nkinematics: delta\n\n");
        assert_eq!(block.render(), BLOCK);
    }

    #[test]
    fn an_option_set_replaces_its_lines_and_keeps_the_others() {
        let (_, mut block) = SaveConfig::split(BLOCK);
        block.set("printer", "delta_radius", "135.000000");
        block.set("bed_mesh default", "points", "0");
        block.set("stepper_a", "angle", "210.000000");
        let expected = BLOCK
            .replace("delta_radius = 134.500000", "delta_radius = 135.000000")
            .replace(
                "points =\n#*# \t-0.012500, 0.025000\n#*# \t0.037500, -0.005000",
                "points = 0",
            )
            + "#*#\n#*# [stepper_a]\n#*# angle = 210.000000\n";
        assert_eq!(block.render(), expected);
    }

    #[test]
    fn a_file_without_a_block_gets_one() {
        let (main, mut block) = SaveConfig::split("[printer]\nkinematics: delta\n");
        assert_eq!(main, "[printer]\nkinematics: delta\n");
        block.set("printer", "delta_radius", "135.000000");
        assert_eq!(
            block.render(),
            format!("{MARKER}\n#*# {NOTICE}\n#*#\n#*# [printer]\n#*# delta_radius = 135.000000\n")
        );
    }
}
