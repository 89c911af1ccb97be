//! The model of instrument measurements: what the global block means, and
//! the leg lengths, frames and residuals of a row at a state.
//!
//! ```text
//! L_i   = l_i + o_{k,i} + s_i q_i                       leg length, session k
//! F_k   = F₀_k ∘ C_F,k                                  instrument frame
//! B_k   = C_B,k ∘ B₀,    C_B,k = (Exp(ω_B + φ_k), τ_B + ρ_k)   body frame
//! pose  M = F_k T(q) B_k         point  P = F_k T(q) E_T
//! ```
//!
//! `o_{k,i}`, `ρ_k` and `φ_k` are unknowns only for later sessions whose
//! model has them (machine.json's `session_model`); `s_i` only when machine.json
//! gives the scales' sigmas (else the design scale). The first session has
//! no offset and no origin shift: the leg lengths `l_i` and the body frame
//! are its own.

use nalgebra::{DVector, Isometry3, Translation3};
use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{Geometry, Params, Vec3, params};
use parcal_observe::FrameCorrection;

use crate::layout::kinematic_params;
use crate::layout::{ParameterGroup, ParameterLayout};

/// The global block's layout and the fixed references of the frames.
#[derive(Debug, Clone, PartialEq)]
pub struct InstrumentModel {
    /// The global block.
    pub layout: ParameterLayout,
    /// The sessions' labels.
    pub sessions: Vec<String>,
    /// `F₀_k` of each session (canonical base → instrument).
    pub tracker_references: Vec<Isometry3<f64>>,
    /// `B₀` (body → canonical platform); the identity without poses.
    pub body_reference: Isometry3<f64>,
    /// The actuators' scales when they are not unknowns (mm per unit).
    pub fixed_scales: [f64; 6],
    /// The tool `E_T` (canonical platform frame, mm) when the layout leaves
    /// it out ([`ParameterLayout::without_tool`]): held, not calibrated.
    pub fixed_tool: Vec3,
}

/// The model at one state of the global block.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelValues {
    /// The kinematic parameters.
    pub params: Params,
    /// Their canonical geometry.
    pub geometry: Geometry,
    /// `s_i` (mm per unit).
    pub scales: [f64; 6],
    /// `C_F,k` of each session.
    pub trackers: Vec<FrameCorrection>,
    /// `C_B,k` of each session.
    pub bodies: Vec<FrameCorrection>,
    /// `o_k` of each session (zero where not an unknown).
    pub offsets: Vec<[f64; 6]>,
}

impl InstrumentModel {
    /// The kinematic parameters at the global block `g`: its first 33, or
    /// its first 30 and the fixed tool.
    pub fn params(&self, g: &DVector<f64>) -> Params {
        if self.layout.has_tool() {
            return kinematic_params(g);
        }
        let mut params = Params::zeros();
        params
            .rows_mut(0, TOOL_OFFSET)
            .copy_from(&g.rows(0, TOOL_OFFSET));
        params.rows_mut(TOOL_OFFSET, 3).copy_from(&self.fixed_tool);
        params
    }

    /// The model's values at the global block `g`.
    pub fn values(&self, g: &DVector<f64>) -> ModelValues {
        let params = self.params(g);
        let six = |group: ParameterGroup| {
            self.layout
                .range(group)
                .map(|r| g.fixed_rows::<6>(r.start).into_owned())
        };
        let scales = six(ParameterGroup::ActuatorScales)
            .map_or(self.fixed_scales, |s| std::array::from_fn(|i| s[i]));
        let body = six(ParameterGroup::BodyFrame).map_or(FrameCorrection::IDENTITY, |p| {
            FrameCorrection::from_params(&p)
        });
        let n = self.sessions.len();
        let trackers = (0..n)
            .map(|session| {
                six(ParameterGroup::TrackerFrame { session })
                    .map_or(FrameCorrection::IDENTITY, |p| {
                        FrameCorrection::from_params(&p)
                    })
            })
            .collect();
        let bodies = (0..n)
            .map(|session| {
                let three = |group: ParameterGroup| {
                    self.layout
                        .range(group)
                        .map_or(Vec3::zeros(), |r| g.fixed_rows::<3>(r.start).into_owned())
                };
                FrameCorrection {
                    rotation: body.rotation + three(ParameterGroup::BodyRotation { session }),
                    translation: body.translation + three(ParameterGroup::BodyOrigin { session }),
                }
            })
            .collect();
        let offsets = (0..n)
            .map(|session| {
                six(ParameterGroup::LegOffsets { session })
                    .map_or([0.0; 6], |o| std::array::from_fn(|i| o[i]))
            })
            .collect();
        ModelValues {
            geometry: params::from_params(&params),
            params,
            scales,
            trackers,
            bodies,
            offsets,
        }
    }

    /// `F_k = F₀_k ∘ C_F,k`.
    pub fn tracker_frame(&self, values: &ModelValues, session: usize) -> Isometry3<f64> {
        self.tracker_references[session] * values.trackers[session].isometry()
    }

    /// `B_k = C_B,k ∘ B₀`.
    pub fn body_frame(&self, values: &ModelValues, session: usize) -> Isometry3<f64> {
        values.bodies[session].isometry() * self.body_reference
    }
}

impl ModelValues {
    /// The extension `o_{k,i} + s_i q_i` of each leg beyond `l_i` (mm): the
    /// `q` that forward and inverse kinematics take.
    pub fn extensions(&self, session: usize, q: &[f64; 6]) -> [f64; 6] {
        std::array::from_fn(|i| self.offsets[session][i] + self.scales[i] * q[i])
    }

    /// `L_i = l_i + o_{k,i} + s_i q_i` (mm).
    pub fn lengths(&self, session: usize, q: &[f64; 6]) -> [f64; 6] {
        let extensions = self.extensions(session, q);
        std::array::from_fn(|i| self.geometry.legs[i] + extensions[i])
    }
}

/// An isometry from a translation and a rotation's matrix.
pub(crate) fn isometry(rotation: nalgebra::Rotation3<f64>, translation: Vec3) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(translation),
        nalgebra::UnitQuaternion::from_rotation_matrix(&rotation),
    )
}
