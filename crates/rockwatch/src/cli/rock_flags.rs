//! The rock of `simulate` and `fragility`: its flags, declared once (clap `flatten`), and the
//! one typed plan they become ([`RockPlan`]): a planar block, or a rock from its mesh whose
//! bodies are taken per direction (docs/general-body.md, docs/meshes.md).

use std::path::PathBuf;

use anyhow::{bail, Context};
use rockwatch::number_text::short_number;
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::mesh::cap::Cap;
use rockwatch_core::mesh::contact::{
    RestingContact, RockGeometry, UpAxis, DEFAULT_CONTACT_TOLERANCE_M,
};

/// The rock's geometry: a rectangle (--width/--height or --half-diagonal/--alpha), a general
/// planar body (--b-plus, --b-minus, --com-height, --rho) or a closed mesh (--mesh).
#[derive(Debug, Clone, clap::Args)]
pub struct GeometryFlags {
    /// Base width B of a rectangular block (m); with --height. Alternatively --half-diagonal
    /// and --alpha, a general body (--b-plus, --b-minus, --com-height, --rho) or --mesh.
    #[arg(long, value_name = "B", requires = "height", conflicts_with = "mesh")]
    pub width: Option<f64>,
    /// Height H of a rectangular block (m).
    #[arg(long, value_name = "H", requires = "width")]
    pub height: Option<f64>,
    /// Half-diagonal R = ½√(B² + H²) of a rectangle (m); with --alpha, instead of --width and
    /// --height.
    #[arg(long = "half-diagonal", value_name = "R", requires = "alpha", conflicts_with_all = ["width", "height", "mesh"])]
    pub half_diagonal: Option<f64>,
    /// Slenderness α = atan(B/H) of a rectangle (degrees), with --half-diagonal.
    #[arg(long, value_name = "DEG", requires = "half_diagonal", conflicts_with_all = ["width", "height"])]
    pub alpha: Option<f64>,
    /// General body (docs/general-body.md): horizontal distance from the centre of mass to
    /// the +x pivot (m). With --b-minus, --com-height and --rho, instead of a rectangle.
    #[arg(long = "b-plus", value_name = "M", requires_all = ["b_minus", "com_height", "rho"], conflicts_with_all = ["width", "height", "half_diagonal", "alpha", "mesh"])]
    pub b_plus: Option<f64>,
    /// General body: horizontal distance from the centre of mass to the −x pivot (m).
    #[arg(long = "b-minus", value_name = "M", requires = "b_plus")]
    pub b_minus: Option<f64>,
    /// General body: height of the centre of mass above the base (m).
    #[arg(long = "com-height", value_name = "M", requires = "b_plus")]
    pub com_height: Option<f64>,
    /// General body: radius of gyration about the centre of mass (m), I_c = m ρ²
    /// (a B × H rectangle has ρ² = (B² + H²)/12).
    #[arg(long, value_name = "M", requires = "b_plus")]
    pub rho: Option<f64>,
    /// A rock from its mesh.
    #[command(flatten)]
    pub mesh: MeshFlags,
    /// The dynamics: `2d`, the planar body of one direction (default), or `3d`, the mesh
    /// rock as one rigid body driven by every ground-motion component (docs/rocking-3d.md;
    /// only with --mesh).
    #[arg(long, value_enum, default_value_t = Model::TwoD)]
    pub model: Model,
}

/// A rock from its closed mesh: the file, its up axis, the contact tolerance and whether to
/// close an open scan (`simulate`, `fragility` and `geometry` declare them here, once).
#[derive(Debug, Clone, clap::Args)]
pub struct MeshFlags {
    /// A rock from its closed mesh (.obj, .ply, .stl; metres): the planar body of each
    /// direction (`rockwatch geometry`, docs/meshes.md), instead of the block flags.
    #[arg(long, value_name = "FILE")]
    pub mesh: Option<PathBuf>,
    /// With --mesh: the mesh axis pointing (roughly) up (x, y, z, optionally signed).
    #[arg(long, value_name = "AXIS", requires = "mesh", default_value = "z")]
    pub up: String,
    /// With --mesh: vertices within this distance of the resting facet's plane touch the
    /// ground (m; default 0: the resting hull facet alone; a wider patch moves the pivots out,
    /// see `rockwatch geometry`'s sensitivity table).
    #[arg(long = "contact-tolerance", value_name = "M", requires = "mesh", default_value_t = DEFAULT_CONTACT_TOLERANCE_M)]
    pub contact_tolerance: f64,
    /// With --mesh: close an open scan (a boulder scanned from above has no base) by its
    /// lowest boundary loop along --up, with a fan from the loop's centroid (docs/meshes.md);
    /// without it an open mesh is refused.
    #[arg(long, requires = "mesh")]
    pub cap: bool,
}

/// A mesh read and analysed: its rock, resting contact and what was capped.
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    pub path: PathBuf,
    pub up: UpAxis,
    pub rock: RockGeometry,
    pub rest: RestingContact,
    /// The loop closed by --cap (None: the mesh was closed).
    pub cap: Option<Cap>,
}

impl MeshFlags {
    /// Reads and analyses --mesh (`None` without it); says on stderr what --cap closed.
    pub fn load(&self) -> anyhow::Result<Option<LoadedMesh>> {
        let Some(path) = &self.mesh else {
            return Ok(None);
        };
        let up = UpAxis::parse(&self.up).map_err(|e| anyhow::anyhow!("--up: {e}"))?;
        if !(self.contact_tolerance.is_finite() && self.contact_tolerance >= 0.0) {
            bail!(
                "--contact-tolerance must be a finite length ≥ 0 (m), got {}",
                self.contact_tolerance
            );
        }
        let (rock, cap) = RockGeometry::read_with(path, self.cap.then_some(up))?;
        let rest = rock.rest(up, self.contact_tolerance)?;
        if let Some(c) = &cap {
            eprintln!(
                "rockwatch: warning: {}: {}",
                path.display(),
                describe_cap(c)
            );
        } else if self.cap {
            eprintln!(
                "rockwatch: {}: --cap: the mesh is closed, nothing to cap",
                path.display()
            );
        }
        Ok(Some(LoadedMesh {
            path: path.clone(),
            up,
            rock,
            rest,
            cap,
        }))
    }
}

/// One line saying what --cap did.
#[must_use]
pub fn describe_cap(c: &Cap) -> String {
    format!(
        "open scan closed by its lowest boundary loop ({} vertices, {} loop{} in all; cap {} m², \
         loop heights within {} m of their mean)",
        c.loop_vertices,
        c.loops,
        if c.loops == 1 { "" } else { "s" },
        short_number(c.area_m2),
        short_number(c.height_spread_m)
    )
}

/// The dynamics of a rock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Model {
    /// The planar body of one direction (docs/general-body.md, docs/meshes.md).
    #[value(name = "2d")]
    TwoD,
    /// 3-D rigid-body rocking of a mesh rock (docs/rocking-3d.md).
    #[value(name = "3d")]
    ThreeD,
}

/// Friction and impact of the rock.
#[derive(Debug, Clone, clap::Args)]
pub struct FrictionFlags {
    /// Static friction coefficient μs.
    #[arg(long = "mu-s", value_name = "MS")]
    pub mu_s: Option<f64>,
    /// Kinetic friction coefficient μk (≤ μs, < 4/3; default μs).
    #[arg(long = "mu-k", value_name = "MK")]
    pub mu_k: Option<f64>,
    /// Restitution of a pure-rocking impact, in [0, 1]: the angular-velocity ratio for a
    /// rectangle (kinetic-energy ratio e² for any body); default Housner's η = 1 − 1.5 sin²α
    /// and its generalisation (ρ² + h² − b_old b_new)/(ρ² + R_new²).
    #[arg(long, value_name = "E")]
    pub restitution: Option<f64>,
}

/// The rock's friction, resolved: μk defaults to μs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Friction {
    pub mu_s: f64,
    pub mu_k: f64,
    pub restitution: Option<f64>,
}

/// What the rock flags describe.
// One plan per command run: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum RockPlan {
    /// A planar block (rectangle or general body).
    Planar(BlockParams),
    /// A rock from its mesh: one planar body per direction ([`MeshPlan::block`]).
    Mesh(MeshPlan),
}

/// A rock from its closed mesh, resting on its contact, with its friction.
#[derive(Debug, Clone)]
pub struct MeshPlan {
    pub mesh: LoadedMesh,
    pub friction: Friction,
    pub model: Model,
}

impl MeshPlan {
    /// The planar block of the direction `azimuth_deg` (degrees clockwise from the mesh's
    /// north axis).
    pub fn block(&self, azimuth_deg: f64) -> anyhow::Result<BlockParams> {
        if !azimuth_deg.is_finite() {
            bail!("azimuth must be a finite number of degrees, got {azimuth_deg}");
        }
        let Friction {
            mu_s,
            mu_k,
            restitution,
        } = self.friction;
        self.mesh
            .rest
            .direction(azimuth_deg)
            .block(mu_s, mu_k, restitution)
            .with_context(|| format!("{} at azimuth {azimuth_deg}°", self.mesh.path.display()))
    }

    /// The rigid body of the 3-D model (its dynamics do not depend on the density:
    /// [`NOMINAL_DENSITY_KG_M3`](rockwatch_core::rocking3d::body::NOMINAL_DENSITY_KG_M3) sets
    /// the reported mass only).
    pub fn body_3d(&self) -> anyhow::Result<rockwatch_core::rocking3d::RockBody> {
        rockwatch_core::rocking3d::RockBody::from_mesh(
            &self.mesh.rock,
            &self.mesh.rest,
            rockwatch_core::rocking3d::body::NOMINAL_DENSITY_KG_M3,
        )
        .with_context(|| format!("{}: the 3-D body", self.mesh.path.display()))
    }
}

impl FrictionFlags {
    /// The friction of the flags: --mu-s required, --mu-k defaulting to it.
    pub fn resolve(&self) -> anyhow::Result<Friction> {
        let Some(mu_s) = self.mu_s else {
            bail!("give the friction: --mu-s (and optionally --mu-k, --restitution)");
        };
        Ok(Friction {
            mu_s,
            mu_k: self.mu_k.unwrap_or(mu_s),
            restitution: self.restitution,
        })
    }
}

impl GeometryFlags {
    /// The rock of the flags with `friction`: reads and analyses the mesh, or validates the
    /// planar block.
    pub fn plan(&self, friction: &FrictionFlags) -> anyhow::Result<RockPlan> {
        let friction = friction.resolve()?;
        let Friction {
            mu_s,
            mu_k,
            restitution,
        } = friction;
        if let Some(mesh) = self.mesh.load()? {
            return Ok(RockPlan::Mesh(MeshPlan {
                mesh,
                friction,
                model: self.model,
            }));
        }
        if self.model == Model::ThreeD {
            bail!("--model 3d needs a mesh rock (--mesh FILE)");
        }
        let params = match self {
            GeometryFlags {
                b_plus: Some(bp),
                b_minus: Some(bm),
                com_height: Some(h),
                rho: Some(rho),
                ..
            } => BlockParams::from_body(*bp, *bm, *h, *rho, mu_s, mu_k, restitution),
            GeometryFlags {
                width: Some(b),
                height: Some(h),
                ..
            } => BlockParams::from_width_height(*b, *h, mu_s, mu_k, restitution),
            GeometryFlags {
                half_diagonal: Some(r),
                alpha: Some(alpha_deg),
                ..
            } => BlockParams::from_r_alpha(*r, alpha_deg.to_radians(), mu_s, mu_k, restitution),
            _ => bail!(
                "give the geometry: --width and --height, --half-diagonal and --alpha, \
                 --b-plus, --b-minus, --com-height and --rho, or --mesh"
            ),
        }
        .context("invalid block")?;
        Ok(RockPlan::Planar(params))
    }
}
