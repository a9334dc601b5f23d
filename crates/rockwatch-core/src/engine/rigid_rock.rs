//! A catalogued mesh rock integrated in 3-D (`model = "3d"`, docs/rocking-3d.md): its nominal
//! rock and ensemble members, each a [`Rock3d`] turned to its heading, driven by the
//! station's three components.
//!
//! # Frames and what is reported
//! A member's body frame is its mesh's east, north, up at rest ([`crate::rocking3d`]); its
//! heading h (true azimuth of the mesh's north axis) turns the station's true (east, north)
//! ground acceleration into the body frame: north_b = a_E·sin h + a_N·cos h,
//! east_b = a_E·cos h − a_N·sin h. What the engine reports of a member is its
//! [`Rock3d::planar_view`] (θ = tilt, θ/α = tilt/α(d), the foot's slide, the mode; module doc of
//! [`crate::rocking3d::report`]), its direction turned to a true azimuth (+ h).
//!
//! # The station-wide rest check
//! A rock whose every member is at rest may be parked in its station's rest group
//! ([`super::rest_group`]) with the limit k = min over members of
//! [`RestCondition::sufficient_ratio`] × (1 − [`REST_GROUP_MARGIN`]) and the members'
//! gravity g. The group's check H = |a_E| + |a_N| ≤ k·(g + a_U) with g + a_U > 0 implies
//! |a_h| ≤ H and then, for every member, (fx² + fy²) ≤ (quick·(g + a_U))² in the rest test's
//! own floating-point arithmetic: the rotation to the body frame and the squares are exact to
//! a few ulps (10⁻¹⁵), far inside the margin, and g + a_U is the same floating-point value in
//! both. So every member would have taken its at-rest path (time += dt, nothing else).

use super::config::{Rock3dSpec, Rock3dSpecError};
use super::rest_group::GroundSample as Sample;
use crate::azimuth::Azimuth;
use crate::catalogue::RigidMember;
use crate::dynamics::RestLimit;
use crate::rocking3d::report::PlanarView;
use crate::rocking3d::{Advance3dError, GroundAccel3d, Mode3d, Rock3d, Rock3dOptions};

/// Relative margin of a 3-D rock's rest-group limit (module doc).
pub const REST_GROUP_MARGIN: f64 = 1e-9;

/// One member: the rock and its heading.
#[derive(Debug, Clone)]
struct Member {
    rock: Rock3d,
    params: RigidMember,
    /// Directions of the mesh's north and east axes.
    north_axis: Azimuth,
    east_axis: Azimuth,
}

impl Member {
    fn new(spec: &Rock3dSpec, params: RigidMember) -> Result<Member, Rock3dSpecError> {
        let rock = Rock3d::new(
            spec.body.clone(),
            params.mu_s,
            params.mu_k,
            Rock3dOptions::default(),
        )?;
        let axis = |deg: f64| {
            Azimuth::from_degrees(deg).map_err(|_| Rock3dSpecError::Heading(params.heading_deg))
        };
        Ok(Member {
            rock,
            params,
            north_axis: axis(params.heading_deg)?,
            east_axis: axis(params.heading_deg + 90.0)?,
        })
    }

    /// The ground acceleration of a station sample in this member's body frame.
    fn ground(&self, s: Sample) -> GroundAccel3d {
        GroundAccel3d {
            east_mps2: self.east_axis.component(s.east, s.north),
            north_mps2: self.north_axis.component(s.east, s.north),
            up_mps2: s.up,
        }
    }

    fn advance(&mut self, prev: Sample, next: Sample, dt_s: f64) -> Result<(), Advance3dError> {
        let (from, to) = (self.ground(prev), self.ground(next));
        self.rock.advance(dt_s, from, to)
    }

    fn overturned(&self) -> bool {
        self.rock.mode() == Mode3d::Overturned
    }

    /// A mesh azimuth (degrees) as a true azimuth in [0, 360).
    fn true_azimuth(&self, mesh_deg: f64) -> f64 {
        (mesh_deg + self.params.heading_deg).rem_euclid(360.0)
    }

    /// The member's [`Rock3d::planar_view`], its direction as a true azimuth.
    fn pose(&self) -> PlanarView {
        let view = self.rock.planar_view();
        PlanarView {
            direction_deg: self.true_azimuth(view.direction_deg),
            ..view
        }
    }
}

/// A 3-D rock in the engine: the nominal rock and its ensemble members (empty: nominal only).
#[derive(Debug, Clone)]
pub(crate) struct RigidRock {
    nominal: Member,
    members: Vec<Member>,
    /// Largest slide of the nominal rock (m, module doc).
    max_slide_m: f64,
}

/// What one step of a rock's members did.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct RigidStep {
    /// The nominal rock left rest during the step: when (s, its clock).
    pub(crate) left_rest_s: Option<f64>,
    /// The nominal rock came to rest or overturned during the step.
    pub(crate) mode_changed: bool,
    /// A member's input was rejected (cannot happen for validated samples).
    pub(crate) failed: bool,
}

impl RigidRock {
    pub(crate) fn new(spec: &Rock3dSpec) -> Result<RigidRock, Rock3dSpecError> {
        Ok(RigidRock {
            nominal: Member::new(spec, spec.nominal)?,
            members: spec
                .members
                .iter()
                .map(|&p| Member::new(spec, p))
                .collect::<Result<_, _>>()?,
            max_slide_m: 0.0,
        })
    }

    /// Advances every member over one sample interval of `dt_s` seconds. Never allocates.
    pub(crate) fn advance(&mut self, prev: Sample, next: Sample, dt_s: f64) -> RigidStep {
        let before = self.nominal.rock.mode();
        let motion_before = self.nominal.rock.stats().last_motion_s;
        let mut failed = self.nominal.advance(prev, next, dt_s).is_err();
        for m in &mut self.members {
            failed |= m.advance(prev, next, dt_s).is_err();
        }
        let after = self.nominal.rock.mode();
        if after != Mode3d::Rest || before != Mode3d::Rest {
            self.max_slide_m = self.max_slide_m.max(self.nominal.rock.foot_slide_m());
        }
        let motion_after = self.nominal.rock.stats().last_motion_s;
        RigidStep {
            left_rest_s: motion_after.filter(|_| motion_after != motion_before),
            mode_changed: before != after,
            failed,
        }
    }

    pub(crate) fn members_len(&self) -> usize {
        self.members.len()
    }

    pub(crate) fn members_overturned(&self) -> usize {
        self.members.iter().filter(|m| m.overturned()).count()
    }

    pub(crate) fn nominal_overturned(&self) -> bool {
        self.nominal.overturned()
    }

    pub(crate) fn pose(&self) -> PlanarView {
        self.nominal.pose()
    }

    /// Clock of the nominal rock (s).
    pub(crate) fn time_s(&self) -> f64 {
        self.nominal.rock.time_s()
    }

    fn all(&self) -> impl Iterator<Item = &Member> {
        std::iter::once(&self.nominal).chain(self.members.iter())
    }

    fn all_mut(&mut self) -> impl Iterator<Item = &mut Member> {
        std::iter::once(&mut self.nominal).chain(self.members.iter_mut())
    }

    /// Every member at rest or fallen.
    pub(crate) fn settled(&self) -> bool {
        self.all()
            .all(|m| matches!(m.rock.mode(), Mode3d::Rest | Mode3d::Overturned))
    }

    /// Every member at rest with its clock at `clock_s`.
    pub(crate) fn resting_at(&self, clock_s: f64) -> bool {
        self.all()
            .all(|m| m.rock.mode() == Mode3d::Rest && m.rock.time_s() == clock_s)
    }

    /// The rest-group limit (module doc).
    pub(crate) fn rest_limit(&self) -> RestLimit {
        self.all().fold(
            RestLimit {
                friction_limit: f64::INFINITY,
                gravity_mps2: f64::INFINITY,
            },
            |acc, m| {
                let rest = m.rock.rest_condition();
                RestLimit {
                    friction_limit: acc
                        .friction_limit
                        .min(rest.sufficient_ratio() * (1.0 - REST_GROUP_MARGIN)),
                    gravity_mps2: acc.gravity_mps2.min(rest.gravity_mps2()),
                }
            },
        )
    }

    /// Leaves the rest group: the members' clocks are set to the group's.
    pub(crate) fn stay_at_rest_until(&mut self, clock_s: f64) {
        for m in self.all_mut() {
            m.rock.stay_at_rest_until(clock_s);
        }
    }

    /// Every member fallen (a journaled overturn restored after a restart).
    pub(crate) fn set_fallen(&mut self) {
        self.all_mut().for_each(|m| m.rock.set_overturned());
    }

    /// Every member stands again at rest (an operator's reset).
    pub(crate) fn reset(&mut self) {
        self.all_mut().for_each(|m| m.rock.reset());
        self.max_slide_m = 0.0;
    }

    /// The same rock: body and every member's heading and friction.
    pub(crate) fn same(&self, other: &RigidRock) -> bool {
        self.members.len() == other.members.len()
            && self.nominal.rock.body() == other.nominal.rock.body()
            && self
                .all()
                .zip(other.all())
                .all(|(a, b)| a.params == b.params)
    }

    /// Heap bytes of the members and of each one's hull vertices (the bodies' short edge
    /// lists and the solvers' scratch are not counted).
    pub(crate) fn heap_bytes(&self) -> usize {
        self.members.capacity() * std::mem::size_of::<Member>()
            + self
                .all()
                .map(|m| std::mem::size_of_val(m.rock.body().vertices()))
                .sum::<usize>()
    }

    /// The nominal rock's response extremes: largest tilt/α and its true azimuth, largest
    /// slide (m, sampled at the input samples while it moves).
    pub(crate) fn extremes(&self) -> (f64, f64, f64) {
        let s = self.nominal.rock.stats();
        (
            s.max_tilt_over_alpha,
            self.nominal.true_azimuth(s.max_tilt_over_alpha_azimuth_deg),
            self.max_slide_m,
        )
    }
}
