//! The study's analysis ([`analyse`]): per block, the exclusion rule's categories, the
//! regressions DM ~ IM (efficiency, sufficiency), vector IMs and the fragility of overturning.

use super::fragility::{fit_lognormal, LognormalFragility};
use super::regression::{
    linear_fit, log_log_fit, multiple_fit, residual_dependence_p, residuals, LinearFit, MultipleFit,
};
use super::{BlockResponse, DemandMeasure, ResponseStatus, StudyConfig, StudyData};
use crate::fragility::fit::FitError;
use crate::ims::{Im, STUDY_IMS, STUDY_IM_COUNT};
use rayon::prelude::*;

/// Why a run is left out of the regressions (or `Used`), and how it is drawn in the plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Category {
    /// Used, DM ≥ the response floor.
    Responding,
    /// Used, DM below the response floor (in the linear regressions, not the log–log ones).
    NoResponse,
    /// Excluded: overturned.
    Overturned,
    /// Excluded: flight.
    Flight,
    /// Excluded: the simulation failed.
    Failed,
    /// Excluded: max |slide| above the threshold.
    SlideAbove,
    /// Excluded: max |θ| above the threshold.
    ThetaAbove,
}

impl Category {
    /// Whether the run enters the regressions.
    #[must_use]
    pub fn is_used(self) -> bool {
        matches!(self, Category::Responding | Category::NoResponse)
    }

    /// Name in the outputs (`responding`, `no-response`, …).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Category::Responding => "responding",
            Category::NoResponse => "no-response",
            Category::Overturned => "overturned",
            Category::Flight => "flight",
            Category::Failed => "failed",
            Category::SlideAbove => "slide-above-max",
            Category::ThetaAbove => "theta-above-max",
        }
    }
}

/// Classifies one response under the exclusion rule and the response floor of `dm`.
/// Order of the tests: failed, overturned, flight, slide above, θ above, then used.
#[must_use]
pub fn categorize(r: &BlockResponse, dm: DemandMeasure, config: &StudyConfig) -> Category {
    let rule = &config.exclusion;
    match r.status {
        ResponseStatus::Failed => return Category::Failed,
        ResponseStatus::Overturned if rule.exclude_overturned => return Category::Overturned,
        ResponseStatus::Flight => return Category::Flight,
        _ => {}
    }
    if r.max_abs_slide_m > rule.max_slide_m {
        Category::SlideAbove
    } else if r.max_abs_theta_rad > rule.max_theta_rad {
        Category::ThetaAbove
    } else if dm.of(r) >= config.floor(dm) {
        Category::Responding
    } else {
        Category::NoResponse
    }
}

/// Counts of the runs of one block by category.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct CategoryCounts {
    pub responding: usize,
    pub no_response: usize,
    pub overturned: usize,
    pub flight: usize,
    pub failed: usize,
    pub slide_above_max: usize,
    pub theta_above_max: usize,
}

impl CategoryCounts {
    /// Runs used in the regressions.
    #[must_use]
    pub fn used(&self) -> usize {
        self.responding + self.no_response
    }

    /// Runs excluded from the regressions.
    #[must_use]
    pub fn excluded(&self) -> usize {
        self.overturned + self.flight + self.failed + self.slide_above_max + self.theta_above_max
    }

    fn add(&mut self, c: Category) {
        match c {
            Category::Responding => self.responding += 1,
            Category::NoResponse => self.no_response += 1,
            Category::Overturned => self.overturned += 1,
            Category::Flight => self.flight += 1,
            Category::Failed => self.failed += 1,
            Category::SlideAbove => self.slide_above_max += 1,
            Category::ThetaAbove => self.theta_above_max += 1,
        }
    }
}

/// Efficiency and sufficiency of one scalar IM for one block.
#[derive(Debug, Clone, PartialEq)]
pub struct ImScore {
    /// Index into [`STUDY_IMS`].
    pub im_index: usize,
    /// DM ~ IM over all used runs.
    pub linear: Option<LinearFit>,
    /// ln DM ~ ln IM over the responding runs (IM > 0).
    pub log: Option<LinearFit>,
    /// R² of DM ~ IM per pair (`None`: undefined, e.g. no run responded).
    pub r2_by_pair: Vec<Option<f64>>,
    /// R² of ln DM ~ ln IM per pair.
    pub r2_log_by_pair: Vec<Option<f64>>,
    /// Standard deviation of the defined per-pair linear R² (the seed's sufficiency criterion).
    pub r2_pair_sd: f64,
    /// max − min of the defined per-pair linear R².
    pub r2_pair_range: f64,
    /// Luco–Cornell p-value of the log–log residuals on Mw.
    pub p_mw_log: f64,
    /// Luco–Cornell p-value of the log–log residuals on R.
    pub p_r_log: f64,
    /// Same test on the linear residuals, on Mw.
    pub p_mw_linear: f64,
    /// Same test on the linear residuals, on R.
    pub p_r_linear: f64,
}

impl ImScore {
    /// The IM.
    #[must_use]
    pub fn im(&self) -> Im {
        STUDY_IMS[self.im_index]
    }

    /// The IM's name as the study spells it ([`Im::study_name`]).
    #[must_use]
    pub fn name(&self) -> String {
        self.im().study_name()
    }

    /// Unit of the IM.
    #[must_use]
    pub fn unit(&self) -> &'static str {
        self.im().unit()
    }

    /// Overall linear R² (NaN if undefined).
    #[must_use]
    pub fn r2(&self) -> f64 {
        self.linear.map_or(f64::NAN, |f| f.r2)
    }

    /// Overall log–log R² (NaN if undefined).
    #[must_use]
    pub fn r2_log(&self) -> f64 {
        self.log.map_or(f64::NAN, |f| f.r2)
    }
}

/// A vector IM (two IMs) for one block.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorScore {
    /// Indices of the two IMs in [`STUDY_IMS`].
    pub ims: [usize; 2],
    /// DM ~ IM1 + IM2 over the used runs.
    pub linear: Option<MultipleFit>,
    /// ln DM ~ ln IM1 + ln IM2 over the responding runs with both IMs > 0.
    pub log: Option<MultipleFit>,
    /// Larger overall linear R² of the two IMs alone.
    pub best_scalar_r2: f64,
    /// Larger overall log–log R² of the two IMs alone.
    pub best_scalar_r2_log: f64,
}

/// The fragility of overturning of one block.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityAnalysis {
    /// Runs in the fragility sample (every run whose simulation succeeded).
    pub n: usize,
    /// Overturned runs among them.
    pub n_overturned: usize,
    /// Fit for every IM, in the order of [`STUDY_IMS`].
    pub fits: Vec<Result<LognormalFragility, FitError>>,
    /// The selected curve (`None`: no IM gave a fit; see `note`).
    pub selected: Option<LognormalFragility>,
    /// How the curve was selected, or why there is none.
    pub note: String,
}

/// The analysis of one block.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockAnalysis {
    /// Index into [`StudyConfig::blocks`].
    pub block_index: usize,
    /// Block name.
    pub name: String,
    /// The DM regressed.
    pub dm: DemandMeasure,
    /// Category of every run, in case order.
    pub categories: Vec<Category>,
    /// Counts by category.
    pub counts: CategoryCounts,
    /// Scalar IMs sorted by overall linear R², best first (undefined last, then IM order).
    pub ranking: Vec<ImScore>,
    /// Vector IMs: the `vector_top` best pairs by linear R², then the named pairs
    /// (PHA with PGV/PGA, the best ASI with CAV) if not already listed.
    pub vector: Vec<VectorScore>,
    /// Fragility of overturning.
    pub fragility: FragilityAnalysis,
}

/// The analysis of a whole study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyAnalysis {
    pub blocks: Vec<BlockAnalysis>,
}

fn sd_and_range(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (var.sqrt(), hi - lo)
}

/// Sorts by a key, descending, NaN last, stable.
pub fn sort_desc_by<T>(items: &mut [T], key: impl Fn(&T) -> f64) {
    items.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        match (ka.is_nan(), kb.is_nan()) {
            (true, true) => std::cmp::Ordering::Equal,
            (true, false) => std::cmp::Ordering::Greater,
            (false, true) => std::cmp::Ordering::Less,
            (false, false) => kb.total_cmp(&ka),
        }
    });
}

fn score_im(
    im_index: usize,
    used: &[usize],
    data: &StudyData,
    dm_values: &[f64],
    floor: f64,
) -> ImScore {
    let x: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[im_index]).collect();
    let y: Vec<f64> = used.iter().map(|&i| dm_values[i]).collect();
    let mw: Vec<f64> = used.iter().map(|&i| data.cases[i].mw).collect();
    let r: Vec<f64> = used.iter().map(|&i| data.cases[i].r_km).collect();
    let linear = linear_fit(&x, &y);
    let log = log_log_fit(&x, &y, floor);
    let (p_mw_linear, p_r_linear) = linear.map_or((f64::NAN, f64::NAN), |f| {
        let res = residuals(&f, &x, &y);
        (
            residual_dependence_p(&res, &mw),
            residual_dependence_p(&res, &r),
        )
    });
    let (p_mw_log, p_r_log) = log.map_or((f64::NAN, f64::NAN), |f| {
        // The responding subset with its Mw and R.
        let keep: Vec<usize> = (0..x.len())
            .filter(|&k| x[k] > 0.0 && y[k] >= floor && y[k] > 0.0)
            .collect();
        let lx: Vec<f64> = keep.iter().map(|&k| x[k].ln()).collect();
        let ly: Vec<f64> = keep.iter().map(|&k| y[k].ln()).collect();
        let res = residuals(&f, &lx, &ly);
        let kmw: Vec<f64> = keep.iter().map(|&k| mw[k]).collect();
        let kr: Vec<f64> = keep.iter().map(|&k| r[k]).collect();
        (
            residual_dependence_p(&res, &kmw),
            residual_dependence_p(&res, &kr),
        )
    });
    let mut r2_by_pair = Vec::with_capacity(data.pairs.len());
    let mut r2_log_by_pair = Vec::with_capacity(data.pairs.len());
    for p in 0..data.pairs.len() {
        let (px, py): (Vec<f64>, Vec<f64>) = used
            .iter()
            .zip(x.iter().zip(&y))
            .filter(|(&i, _)| data.cases[i].pair_index == p)
            .map(|(_, (&a, &b))| (a, b))
            .unzip();
        r2_by_pair.push(linear_fit(&px, &py).map(|f| f.r2));
        r2_log_by_pair.push(log_log_fit(&px, &py, floor).map(|f| f.r2));
    }
    let defined: Vec<f64> = r2_by_pair.iter().flatten().copied().collect();
    let (r2_pair_sd, r2_pair_range) = sd_and_range(&defined);
    ImScore {
        im_index,
        linear,
        log,
        r2_by_pair,
        r2_log_by_pair,
        r2_pair_sd,
        r2_pair_range,
        p_mw_log,
        p_r_log,
        p_mw_linear,
        p_r_linear,
    }
}

fn vector_score(
    a: usize,
    b: usize,
    used: &[usize],
    data: &StudyData,
    dm_values: &[f64],
    floor: f64,
    scalar: &[ImScore],
) -> VectorScore {
    let x1: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[a]).collect();
    let x2: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[b]).collect();
    let y: Vec<f64> = used.iter().map(|&i| dm_values[i]).collect();
    let linear = multiple_fit(&[&x1, &x2], &y);
    let keep: Vec<usize> = (0..y.len())
        .filter(|&k| x1[k] > 0.0 && x2[k] > 0.0 && y[k] >= floor && y[k] > 0.0)
        .collect();
    let l1: Vec<f64> = keep.iter().map(|&k| x1[k].ln()).collect();
    let l2: Vec<f64> = keep.iter().map(|&k| x2[k].ln()).collect();
    let ly: Vec<f64> = keep.iter().map(|&k| y[k].ln()).collect();
    let log = multiple_fit(&[&l1, &l2], &ly);
    let by_index = |i: usize| scalar.iter().find(|s| s.im_index == i);
    let best = |f: fn(&ImScore) -> f64| {
        [a, b]
            .iter()
            .filter_map(|&i| by_index(i).map(f))
            .filter(|v| !v.is_nan())
            .fold(f64::NAN, f64::max)
    };
    VectorScore {
        ims: [a, b],
        linear,
        log,
        best_scalar_r2: best(ImScore::r2),
        best_scalar_r2_log: best(ImScore::r2_log),
    }
}

fn fragility_analysis(
    config: &StudyConfig,
    data: &StudyData,
    block_index: usize,
) -> FragilityAnalysis {
    let sample: Vec<usize> = (0..data.cases.len())
        .filter(|&i| data.responses[i][block_index].status != ResponseStatus::Failed)
        .collect();
    let event: Vec<bool> = sample
        .iter()
        .map(|&i| data.responses[i][block_index].status == ResponseStatus::Overturned)
        .collect();
    let n_overturned = event.iter().filter(|&&e| e).count();
    let fits: Vec<_> = (0..STUDY_IM_COUNT)
        .map(|j| {
            let im: Vec<f64> = sample.iter().map(|&i| data.cases[i].ims[j]).collect();
            fit_lognormal(STUDY_IMS[j], &im, &event)
        })
        .collect();
    let (selected, note) = match &config.fragility_im {
        Some(im) => {
            let name = im.study_name();
            let j = STUDY_IMS.iter().position(|x| x == im).unwrap_or(0);
            match &fits[j] {
                Ok(f) => (Some(f.clone()), format!("IM {name} chosen by the user")),
                Err(e) => (None, format!("no curve for IM {name}: {e}")),
            }
        }
        None => {
            // Largest likelihood among the IMs that are positive for every run (equal n).
            let best = fits
                .iter()
                .filter_map(|f| f.as_ref().ok())
                .filter(|f| f.n == sample.len() && f.b > 0.0)
                .fold(None::<&LognormalFragility>, |acc, f| match acc {
                    Some(a) if a.log_likelihood >= f.log_likelihood => Some(a),
                    _ => Some(f),
                });
            match best {
                Some(f) => (
                    Some(f.clone()),
                    format!(
                        "IM of largest likelihood among the {} IMs fitted to all {} runs",
                        fits.iter()
                            .filter(|r| r.as_ref().is_ok_and(|f| f.n == sample.len()))
                            .count(),
                        sample.len()
                    ),
                ),
                None => {
                    let reason = fits.iter().find_map(|f| f.as_ref().err()).map_or_else(
                        || "no IM gave an increasing curve".to_string(),
                        |e| e.to_string(),
                    );
                    (None, format!("no fragility curve: {reason}"))
                }
            }
        }
    };
    FragilityAnalysis {
        n: sample.len(),
        n_overturned,
        fits,
        selected,
        note,
    }
}

/// Analyses one block: categories, scalar and vector regressions, fragility.
#[must_use]
pub fn analyse_block(config: &StudyConfig, data: &StudyData, block_index: usize) -> BlockAnalysis {
    let block = &config.blocks[block_index];
    let dm = block.dm;
    let floor = config.floor(dm);
    let categories: Vec<Category> = data
        .responses
        .iter()
        .map(|r| categorize(&r[block_index], dm, config))
        .collect();
    let mut counts = CategoryCounts::default();
    for &c in &categories {
        counts.add(c);
    }
    let used: Vec<usize> = (0..categories.len())
        .filter(|&i| categories[i].is_used())
        .collect();
    let dm_values: Vec<f64> = data
        .responses
        .iter()
        .map(|r| dm.of(&r[block_index]))
        .collect();
    let mut ranking: Vec<ImScore> = (0..STUDY_IM_COUNT)
        .into_par_iter()
        .map(|j| score_im(j, &used, data, &dm_values, floor))
        .collect();
    sort_desc_by(&mut ranking, ImScore::r2);

    let all_pairs: Vec<(usize, usize)> = (0..STUDY_IM_COUNT)
        .flat_map(|a| ((a + 1)..STUDY_IM_COUNT).map(move |b| (a, b)))
        .collect();
    let mut vectors: Vec<VectorScore> = all_pairs
        .par_iter()
        .map(|&(a, b)| vector_score(a, b, &used, data, &dm_values, floor, &ranking))
        .collect();
    sort_desc_by(&mut vectors, |v| {
        v.linear.as_ref().map_or(f64::NAN, |f| f.r2)
    });
    let mut vector: Vec<VectorScore> = vectors.iter().take(config.vector_top).cloned().collect();
    let index_of = |im: Im| STUDY_IMS.iter().position(|x| *x == im);
    let best_asi = ranking
        .iter()
        .find(|s| matches!(s.im(), Im::Asi(_)))
        .map(|s| s.im_index);
    let named = [
        index_of(Im::Pga).zip(index_of(Im::PgvPga)),
        best_asi.zip(index_of(Im::Cav)),
    ];
    for (a, b) in named.into_iter().flatten() {
        let key = [a.min(b), a.max(b)];
        if !vector.iter().any(|v| v.ims == key) {
            if let Some(v) = vectors.iter().find(|v| v.ims == key) {
                vector.push(v.clone());
            }
        }
    }

    BlockAnalysis {
        block_index,
        name: block.name.clone(),
        dm,
        categories,
        counts,
        ranking,
        vector,
        fragility: fragility_analysis(config, data, block_index),
    }
}

/// Analyses every block of a study.
#[must_use]
pub fn analyse(config: &StudyConfig, data: &StudyData) -> StudyAnalysis {
    StudyAnalysis {
        blocks: (0..config.blocks.len())
            .map(|b| analyse_block(config, data, b))
            .collect(),
    }
}
