//! G-code lines as RepRapFirmware reads them: a command letter and number
//! (`M665`, `G31`), then parameters, each a letter and the value that
//! follows it up to the next space or letter (`L250.1:250.3:249.9`,
//! `R130`), a quoted string or a `{...}` expression running to its end;
//! `;` starts a comment to the end of the line; an `N` line number before
//! the command and a `*` checksum after it are ignored. Letters are read
//! case-insensitively. A `:`-separated list is a float array
//! (RepRapFirmware's `GetFloatArray`). Meta-commands (`if`, `var`) are
//! skipped and expressions are not evaluated: a parameter parcal needs
//! that holds one is refused.

use crate::files::bounded_number;

/// One command and its parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// `G`, `M` or `T`.
    pub letter: char,
    /// The command number (`665` of `M665`).
    pub number: u32,
    /// The parameters in the order given: letter (upper case) and raw value.
    pub parameters: Vec<(char, String)>,
}

impl Command {
    /// The value of parameter `letter` (its last occurrence), if given.
    pub fn get(&self, letter: char) -> Option<&str> {
        self.parameters
            .iter()
            .rev()
            .find(|(l, _)| *l == letter)
            .map(|(_, v)| v.as_str())
    }

    /// The number of parameter `letter`, if given; an error naming the
    /// command and the parameter for anything but one finite number.
    pub fn float(&self, letter: char) -> Result<Option<f64>, String> {
        self.get(letter)
            .map(|v| self.number_of(letter, v))
            .transpose()
    }

    /// For each of `letters` the command gives, in order, `set(k, value)`
    /// with `k` the letter's index in `letters`; the first error of a
    /// value or of `set`.
    pub fn each_float(
        &self,
        letters: &[char],
        mut set: impl FnMut(usize, f64) -> Result<(), String>,
    ) -> Result<(), String> {
        for (k, &letter) in letters.iter().enumerate() {
            if let Some(v) = self.float(letter)? {
                set(k, v)?;
            }
        }
        Ok(())
    }

    /// The `:`-separated numbers of parameter `letter`, if given.
    pub fn floats(&self, letter: char) -> Result<Option<Vec<f64>>, String> {
        self.get(letter)
            .map(|v| {
                v.split(':')
                    .map(|part| self.number_of(letter, part))
                    .collect()
            })
            .transpose()
    }

    fn number_of(&self, letter: char, value: &str) -> Result<f64, String> {
        let text = value.trim();
        if text.starts_with('{') {
            return Err(format!(
                "{}{} parameter {letter}: the expression {value} is not evaluated; give a number",
                self.letter, self.number
            ));
        }
        let is_number = !text.is_empty()
            && text
                .chars()
                .all(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+'));
        let number = if is_number {
            bounded_number(text)
        } else if text.is_empty() {
            Err("no number follows the letter".to_string())
        } else {
            Err(format!("'{value}' is not a number"))
        };
        number.map_err(|why| format!("{}{} parameter {letter}: {why}", self.letter, self.number))
    }
}

/// The command on one line, `None` for a blank or comment-only line or a
/// line that is not a G, M or T command (a meta-command); an error for a
/// malformed command.
pub fn parse_line(line: &str) -> Result<Option<Command>, String> {
    let mut chars = line.trim_start().chars().peekable();
    // An optional line number N<digits>.
    if chars.next_if(|c| matches!(c, 'N' | 'n')).is_some() {
        while chars.next_if(|c| c.is_ascii_digit()).is_some() {}
        while chars.next_if(|c| c.is_whitespace()).is_some() {}
    }
    let letter = match chars.next_if(|c| matches!(c.to_ascii_uppercase(), 'G' | 'M' | 'T')) {
        Some(c) => c.to_ascii_uppercase(),
        None => return Ok(None),
    };
    let digits: String = std::iter::from_fn(|| chars.next_if(|c| c.is_ascii_digit())).collect();
    if digits.is_empty() {
        // A word such as `mkdir` or `echo`: not a G/M/T command.
        return Ok(None);
    }
    let number = digits
        .parse::<u32>()
        .map_err(|_| format!("{letter}{digits}: command number out of range"))?;
    // A sub-function (`G29.1`) is part of the command.
    if chars.next_if_eq(&'.').is_some() {
        while chars.next_if(|c| c.is_ascii_digit()).is_some() {}
    }
    let mut parameters: Vec<(char, String)> = Vec::new();
    while let Some(c) = chars.next() {
        match c {
            ';' | '*' => break,
            _ if c.is_whitespace() => continue,
            _ if c.is_ascii_alphabetic() => {}
            _ => {
                return Err(format!(
                    "{letter}{number}: '{c}' where a parameter letter should be"
                ));
            }
        }
        let mut value = String::new();
        while let Some(&next) = chars.peek() {
            if next.is_whitespace() || next.is_ascii_alphabetic() || next == ';' || next == '*' {
                break;
            }
            chars.next();
            value.push(next);
            // A quoted string or a braced expression runs to its end,
            // letters, spaces and semicolons included.
            let close = match next {
                '"' => '"',
                '{' => '}',
                _ => continue,
            };
            for inner in chars.by_ref() {
                value.push(inner);
                if inner == close {
                    break;
                }
            }
        }
        parameters.push((c.to_ascii_uppercase(), value));
    }
    Ok(Some(Command {
        letter,
        number,
        parameters,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_commands_parameters_and_arrays() {
        let command = parse_line("N12 m665 L250.1:250.3:249.9 R130 h300.5 ; a comment X9*71")
            .unwrap()
            .unwrap();
        assert_eq!((command.letter, command.number), ('M', 665));
        assert_eq!(
            command.floats('L').unwrap(),
            Some(vec![250.1, 250.3, 249.9])
        );
        assert_eq!(command.float('R').unwrap(), Some(130.0));
        assert_eq!(command.float('H').unwrap(), Some(300.5));
        assert_eq!(command.float('X').unwrap(), None);
        // Parameters need no spaces between them.
        let packed = parse_line("M666X-0.1Y0.2Z-0.05").unwrap().unwrap();
        assert_eq!(packed.float('Y').unwrap(), Some(0.2));
        assert_eq!(packed.float('Z').unwrap(), Some(-0.05));
    }

    #[test]
    fn skips_comments_and_meta_commands_and_refuses_bad_values() {
        assert_eq!(parse_line("   ; only a comment").unwrap(), None);
        assert_eq!(parse_line("").unwrap(), None);
        assert_eq!(parse_line("if heaters[0].current > 40").unwrap(), None);
        // No exponents in G-code: the `e` starts a parameter E.
        let command = parse_line("M665 R1e3").unwrap().unwrap();
        assert_eq!(command.float('R').unwrap(), Some(1.0));
        assert_eq!(command.float('E').unwrap(), Some(3.0));
        let command = parse_line("M665 R1.2.3").unwrap().unwrap();
        assert_eq!(
            command.float('R').unwrap_err(),
            "M665 parameter R: '1.2.3' is not a number"
        );
        let command = parse_line("M665 R").unwrap().unwrap();
        assert!(command.float('R').unwrap_err().contains("parameter R"));
        let command = parse_line("M665 R{global.r * 2} L270").unwrap().unwrap();
        assert_eq!(
            command.float('R').unwrap_err(),
            "M665 parameter R: the expression {global.r * 2} is not evaluated; give a number"
        );
        assert_eq!(command.float('L').unwrap(), Some(270.0));
        // A string may hold letters, spaces and semicolons.
        let command = parse_line("M550 P\"My; X9 printer\" X1 ; comment")
            .unwrap()
            .unwrap();
        assert_eq!(command.get('P'), Some("\"My; X9 printer\""));
        assert_eq!(command.float('X').unwrap(), Some(1.0));
    }
}
