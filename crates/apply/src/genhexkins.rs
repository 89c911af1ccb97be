//! A LinuxCNC genhexkins HAL snippet of the calibrated geometry.
//!
//! Conventions of genhexkins (LinuxCNC, `src/emc/kinematics/genhexkins.c`,
//! read at commit 032ef12ca96c8c9b9c85d6ca136db96c04fa1fae):
//!
//! - pins `genhexkins.base.N.x|y|z` (base joint `b[N]`, world frame) and
//!   `genhexkins.platform.N.x|y|z` (platform joint `a[N]`, platform frame),
//!   `N = 0..5`: parcal's joint `i` is `N = i - 1`;
//! - the world position `tran` is the platform frame's origin,
//!   `aw = R a + tran`; `R = Rz(c) Ry(b) Rx(a)` from the roll, pitch, yaw
//!   words `a, b, c` in degrees;
//! - a joint position is the whole strut length `|R a_N + tran - b_N|`
//!   (inverse kinematics), in machine units;
//! - `genhexkins.spindle-offset` and `genhexkins.tool-offset` are added to
//!   the z of every base and platform joint.
//!
//! So the snippet writes the base joints in the design frame and the
//! platform joints relative to the tool tip (`E_i - E_T`, platform axes):
//! the controlled point `tran` is the tool tip of docs/apply.md's targets.
//! Joint `N`'s position must be leg `i`'s length `l_i + s_i q_i`: the
//! snippet states `l_i` and `s_i` for the joint's scale and home in the INI
//! file; with spindle-offset and tool-offset at 0.

use std::fmt::Write as _;

use parcal_kinematics::Vec3;

use crate::{AppliedModel, UNSEEN_TOOL};

/// The HAL snippet (module doc). Numbers in Rust's shortest round-trip
/// form.
pub fn hal_snippet(model: &AppliedModel) -> String {
    let g = &model.calibrated;
    let mut out = String::new();
    let mut line = |text: String| {
        out.push_str(&text);
        out.push('\n');
    };
    line("# parcal: calibrated geometry for LinuxCNC genhexkins (docs/apply.md)".into());
    line("# Base joints in the design frame; platform joints relative to the tool tip.".into());
    line("# Lengths in mm; genhexkins.spindle-offset and genhexkins.tool-offset must be 0.".into());
    if !model.tool_calibrated {
        line(format!("# {UNSEEN_TOOL}"));
    }
    let set = |out: &mut String, body: &str, n: usize, p: &Vec3| {
        for (axis, v) in ["x", "y", "z"].iter().zip(p.iter()) {
            writeln!(out, "setp genhexkins.{body}.{n}.{axis} {v}").expect("writing to a String");
        }
    };
    for (n, b) in g.base.iter().enumerate() {
        set(&mut out, "base", n, b);
    }
    for (n, e) in g.platform.iter().enumerate() {
        set(&mut out, "platform", n, &(e - g.tool));
    }
    writeln!(
        out,
        "# Joint N (parcal leg N+1) position = strut length = l + s * q, q the reading in {}:",
        model.unit
    )
    .expect("writing to a String");
    for n in 0..6 {
        writeln!(
            out,
            "#   joint {n}: l = {} mm, s = {} mm/{}",
            g.legs[n], model.scale[n], model.unit
        )
        .expect("writing to a String");
    }
    out
}
