//! A hexapod's plan as `parcal plan` asks for it, for every front end
//! (the binary's flags, Python's keyword arguments): the tilt, whether the
//! plan is of ball touches or of platform poses measured by an instrument
//! (docs/plan.md, docs/plan-poses.md), and a pose plan's options, each
//! refusal naming the option as the front end spells it
//! ([`Spelling`]).

use parcal_plan::bounds;
use parcal_plan::tracker::PosePlanOptions;
use parcal_plan::{Criterion, PlanOptions};
use parcal_simulate::mechanism::Spelling;
use parcal_simulate::{TrackerKind, Workspace};

/// What an instrument measures at each planned pose, by its name
/// (`parcal plan --tracker`'s).
pub const TRACKERS: [(&str, TrackerKind); 3] = [
    ("poses", TrackerKind::Poses),
    ("points", TrackerKind::Points),
    ("both", TrackerKind::Both),
];

/// The instrument named `name` ([`TRACKERS`]), or a refusal naming the
/// option `tracker` and the names.
pub fn tracker_kind(name: &str, spelling: Spelling) -> Result<TrackerKind, String> {
    crate::named::by_name(&TRACKERS, name).ok_or_else(|| {
        let names: Vec<&str> = TRACKERS.iter().map(|(n, _)| *n).collect();
        format!(
            "{}: {name:?} is not one of {}",
            spelling.name("tracker"),
            names.join(", ")
        )
    })
}

/// The largest tilt of a hexapod's plan (degrees), which every plan
/// needs, in `[0, 90)`.
pub fn tilt(tilt: Option<f64>, spelling: Spelling) -> Result<f64, String> {
    let name = spelling.name("tilt");
    let tilt = tilt.ok_or_else(|| format!("{name} is needed for a hexapod's plan"))?;
    if tilt.is_finite() && (0.0..90.0).contains(&tilt) {
        Ok(tilt)
    } else {
        Err(format!("{name} must be in [0, 90) degrees, got {tilt}"))
    }
}

/// The instrument a hexapod's plan is for: the one asked for, else poses
/// when there are no balls to touch (a directory without artefacts.json,
/// a dataset without balls); `None`: a plan of ball touches.
pub fn planned_tracker(asked: Option<TrackerKind>, has_balls: bool) -> Option<TrackerKind> {
    asked.or((!has_balls).then_some(TrackerKind::Poses))
}

/// The budget of a plan of ball touches, refusing a pose plan's
/// `sessions` other than 1 and a missing `contacts`.
pub fn touch_contacts(
    contacts: Option<usize>,
    sessions: usize,
    spelling: Spelling,
) -> Result<usize, String> {
    if sessions != 1 {
        return Err(format!(
            "{} applies to pose plans only ({})",
            spelling.name("sessions"),
            given(spelling, "tracker")
        ));
    }
    contacts.ok_or_else(|| {
        format!(
            "{} is needed for a plan of ball touches",
            spelling.name("contacts")
        )
    })
}

/// The workspace `[HALF_WIDTH, Z_MIN, Z_MAX]` of a pose plan (mm, design
/// base frame): three finite numbers, `HALF_WIDTH >= 0`, `Z_MIN <= Z_MAX`;
/// a refusal says what it must be (`given`: the value as the front end
/// wrote it).
pub fn workspace(values: &[f64], given: &str, spelling: Spelling) -> Result<Workspace, String> {
    match *values {
        [half_width, low, high]
            if values.iter().all(|v| v.is_finite()) && half_width >= 0.0 && low <= high =>
        {
            Ok(Workspace {
                half_width,
                height: [low, high],
            })
        }
        _ => Err(match spelling {
            Spelling::Flags => format!(
                "{given:?}: three finite numbers HALF_WIDTH,Z_MIN,Z_MAX with HALF_WIDTH >= 0 and Z_MIN <= Z_MAX"
            ),
            Spelling::Keywords => format!(
                "workspace: {given} is not three finite numbers (half_width, z_min, z_max) with half_width >= 0 and z_min <= z_max"
            ),
        }),
    }
}

/// What a front end was asked for a pose plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PosePlanRequest {
    /// The budget (`poses`), if given.
    pub poses: Option<usize>,
    /// What the instrument measures.
    pub kind: TrackerKind,
    /// Where the platform origin may go, if given.
    pub workspace: Option<Workspace>,
    /// Largest |roll|, |pitch|, |yaw| (degrees; [`tilt`]).
    pub tilt_degrees: f64,
    /// What is minimised.
    pub criterion: Criterion,
    /// Measuring sessions.
    pub sessions: usize,
    /// Whether an option of ball touches only was given (`after`,
    /// `per_ball`, `min_balls`, `radius`).
    pub touch_options: bool,
}

/// The options of the pose plan `request` asks for, as `parcal plan
/// --tracker` plans it (the exchange passes of a touch plan; the counts
/// within [`bounds::POSES`] and [`bounds::SESSIONS`]), or a refusal naming
/// the option missing or out of place.
pub fn pose_plan_options(
    request: &PosePlanRequest,
    spelling: Spelling,
) -> Result<PosePlanOptions, String> {
    let poses = request.poses.ok_or_else(|| match spelling {
        Spelling::Flags => {
            "--poses is needed for a pose plan (--tracker, or DIR without artefacts.json)"
                .to_string()
        }
        Spelling::Keywords => {
            "poses is needed for a pose plan (tracker=, or a dataset without balls)".to_string()
        }
    })?;
    let workspace = request.workspace.ok_or(match spelling {
        Spelling::Flags => "--workspace HALF_WIDTH,Z_MIN,Z_MAX is needed for a pose plan",
        Spelling::Keywords => "workspace=(half_width, z_min, z_max) is needed for a pose plan",
    })?;
    if request.touch_options {
        let names: Vec<String> = ["after", "per_ball", "min_balls"]
            .iter()
            .map(|name| spelling.name(name))
            .collect();
        return Err(format!(
            "{} and {} apply to ball touches only",
            names.join(", "),
            spelling.name("radius")
        ));
    }
    bounds::POSES.check(&spelling.name("poses"), poses)?;
    bounds::SESSIONS.check(&spelling.name("sessions"), request.sessions)?;
    Ok(PosePlanOptions {
        poses,
        kind: request.kind,
        workspace,
        tilt_degrees: request.tilt_degrees,
        criterion: request.criterion,
        passes: PlanOptions::new(1, 0.0).passes,
        sessions: request.sessions,
    })
}

/// The option `name` as a front end says it was given: `--tracker`,
/// `tracker=`.
fn given(spelling: Spelling, name: &str) -> String {
    match spelling {
        Spelling::Flags => spelling.name(name),
        Spelling::Keywords => format!("{name}="),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request() -> PosePlanRequest {
        PosePlanRequest {
            poses: Some(30),
            kind: TrackerKind::Points,
            workspace: Some(Workspace {
                half_width: 60.0,
                height: [300.0, 380.0],
            }),
            tilt_degrees: 10.0,
            criterion: Criterion::D,
            sessions: 2,
            touch_options: false,
        }
    }

    #[test]
    fn a_pose_plans_options_are_those_asked_for_or_refused_by_name() {
        let options = pose_plan_options(&request(), Spelling::Keywords).unwrap();
        assert_eq!(
            (options.poses, options.kind, options.sessions),
            (30, TrackerKind::Points, 2)
        );
        assert_eq!(options.passes, PlanOptions::new(1, 0.0).passes);
        for (spelling, named) in [(Spelling::Flags, "--poses"), (Spelling::Keywords, "poses")] {
            let missing = PosePlanRequest {
                poses: None,
                ..request()
            };
            let message = pose_plan_options(&missing, spelling).unwrap_err();
            assert!(
                message.starts_with(&format!("{named} is needed")),
                "{message}"
            );
            let zero = PosePlanRequest {
                poses: Some(0),
                ..request()
            };
            let message = pose_plan_options(&zero, spelling).unwrap_err();
            assert!(
                message.starts_with(&format!("{named} 0: must be a whole number from 1 to 1000")),
                "{message}"
            );
        }
        let touches = PosePlanRequest {
            touch_options: true,
            ..request()
        };
        assert_eq!(
            pose_plan_options(&touches, Spelling::Keywords).unwrap_err(),
            "after, per_ball, min_balls and radius apply to ball touches only"
        );
        assert_eq!(
            pose_plan_options(&touches, Spelling::Flags).unwrap_err(),
            "--after, --per-ball, --min-balls and --radius apply to ball touches only"
        );
        let open = PosePlanRequest {
            workspace: None,
            ..request()
        };
        assert!(
            pose_plan_options(&open, Spelling::Keywords)
                .unwrap_err()
                .starts_with("workspace=(half_width, z_min, z_max) is needed")
        );
    }

    #[test]
    fn workspaces_tilts_and_trackers_are_checked() {
        let box_ = workspace(&[60.0, 300.0, 380.0], "", Spelling::Flags).unwrap();
        assert_eq!((box_.half_width, box_.height), (60.0, [300.0, 380.0]));
        for bad in [
            &[-1.0, 300.0, 380.0][..],
            &[60.0, 380.0, 300.0],
            &[60.0, f64::NAN, 380.0],
            &[60.0, 300.0],
        ] {
            let message = workspace(bad, "(w)", Spelling::Keywords).unwrap_err();
            assert!(
                message.starts_with("workspace: (w) is not three"),
                "{message}"
            );
        }
        assert_eq!(tilt(Some(10.0), Spelling::Keywords), Ok(10.0));
        assert_eq!(
            tilt(Some(90.0), Spelling::Flags).unwrap_err(),
            "--tilt must be in [0, 90) degrees, got 90"
        );
        assert_eq!(
            tilt(None, Spelling::Keywords).unwrap_err(),
            "tilt is needed for a hexapod's plan"
        );
        assert_eq!(
            tracker_kind("both", Spelling::Keywords),
            Ok(TrackerKind::Both)
        );
        assert_eq!(
            tracker_kind("pose", Spelling::Keywords).unwrap_err(),
            "tracker: \"pose\" is not one of poses, points, both"
        );
        assert_eq!(planned_tracker(None, true), None);
        assert_eq!(planned_tracker(None, false), Some(TrackerKind::Poses));
        assert_eq!(
            planned_tracker(Some(TrackerKind::Both), true),
            Some(TrackerKind::Both)
        );
        assert_eq!(
            touch_contacts(Some(40), 2, Spelling::Keywords).unwrap_err(),
            "sessions applies to pose plans only (tracker=)"
        );
        assert_eq!(
            touch_contacts(None, 1, Spelling::Flags).unwrap_err(),
            "--contacts is needed for a plan of ball touches"
        );
    }
}
