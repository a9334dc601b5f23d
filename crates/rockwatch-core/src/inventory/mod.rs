//! Station metadata: the channel epochs of FDSN StationXML documents (parser in
//! `stationxml.rs`, units in `units.rs`) and what rockwatch needs of them to turn a channel's
//! raw counts into ground acceleration: the gain in (m/s²)/count, the sensor axis (azimuth
//! and dip) and the sampling rate, for the epoch that contains a given time.
//!
//! Conventions (StationXML, SEED):
//! - `InstrumentSensitivity/Value` is in **output units per input unit** (counts per m/s² for
//!   an accelerometer). The gain rockwatch applies is its inverse in m/s² per count:
//!   `gain = to_mps2(input units) / value`, so `a_mps2 = counts × gain` (ObsPy's
//!   `remove_sensitivity`). A negative sensitivity (reversed polarity) gives a negative gain.
//! - Azimuth: degrees clockwise from north; Dip: degrees **down** from horizontal (−90 = up,
//!   the usual vertical channel). See [`crate::azimuth::ChannelAxis`].
//! - Epochs are half-open, `[start, end)`, `end = None` open-ended: when one epoch ends where
//!   the next begins, the later one is chosen.
//!
//! Only acceleration input units are usable directly. Velocity channels are refused with a
//! reason unless the caller asks for differentiation
//! ([`ChannelEpoch::calibration_with`] with `differentiate_velocity`): their [`Calibration`]
//! then says [`SensorInput::Velocity`] and the samples are differentiated on the sample grid
//! ([`crate::differentiate`]) before the gain is applied. Anything else is refused.

mod stationxml;
pub mod units;

use std::path::Path;

use crate::azimuth::{Azimuth, ChannelAxis};
use crate::utc::format_utc_ns;
use units::{classify_unit, UnitKind};

/// The channel epochs of one or more StationXML documents.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Inventory {
    /// Every channel epoch, in document order (documents in the order read).
    pub channels: Vec<ChannelEpoch>,
}

/// One `<Channel>` element: a channel code over one epoch, with what rockwatch uses of it.
/// Fields missing from the document are `None`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelEpoch {
    /// The document the epoch came from (for messages).
    pub source: String,
    pub network: String,
    pub station: String,
    /// Location code (often empty).
    pub location: String,
    pub channel: String,
    /// Start of the epoch (`startDate`), ns since 1970-01-01T00:00:00Z UTC.
    pub start_ns: Option<i128>,
    /// End of the epoch (`endDate`, excluded); `None` = open-ended.
    pub end_ns: Option<i128>,
    /// Sampling rate (Hz).
    pub sample_rate_hz: Option<f64>,
    /// Sensor axis azimuth, degrees clockwise from north.
    pub azimuth_deg: Option<f64>,
    /// Sensor axis dip, degrees down from horizontal (−90 = up).
    pub dip_deg: Option<f64>,
    /// The overall sensitivity of the response, if given.
    pub sensitivity: Option<Sensitivity>,
}

/// `Response/InstrumentSensitivity`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    /// Output units per input unit (counts per m/s² for an accelerometer).
    pub value: f64,
    /// Frequency at which `value` holds (Hz).
    pub frequency_hz: Option<f64>,
    /// `InputUnits/Name` as written (`M/S**2`, `m/s`, …).
    pub input_units: String,
    /// `OutputUnits/Name` as written (`COUNTS`, …), if given.
    pub output_units: Option<String>,
}

/// What a channel's samples measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorInput {
    /// Acceleration: `a = counts × gain`.
    Acceleration,
    /// Velocity, to be differentiated on the sample grid: `a = d(counts)/dt × gain`, the gain
    /// then being (m/s) per count, i.e. m/s² per (count/s).
    Velocity,
}

/// What a usable channel epoch gives: counts to m/s² along a known axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// m/s² per count (sign included: a negative sensitivity reverses polarity); for a
    /// [`SensorInput::Velocity`] channel, m/s² per (count/s) — (m/s) per count — applied to
    /// the counts' time derivative.
    pub gain_mps2_per_count: f64,
    /// Acceleration, or velocity to differentiate.
    pub input: SensorInput,
    /// The sensor's sensitive axis.
    pub axis: ChannelAxis,
    /// Sampling rate (Hz).
    pub sample_rate_hz: f64,
}

/// Largest |gain| accepted (m/s² per count): 1 count = 1000 m/s² (≈ 100 g) is no real
/// digitizer; such a gain is a unit or sensitivity mistake.
pub const MAX_ABS_GAIN_MPS2_PER_COUNT: f64 = 1e3;

/// Relative difference between a record's and the inventory's sampling rate beyond which the
/// record is refused (clock drift of a real digitizer is far below 1e-4).
pub const MAX_RATE_MISMATCH: f64 = 1e-4;

/// Lowest sampling rate (Hz) of a usable channel. The ground acceleration that starts a block
/// rocking or sliding (its alerts' onset is a threshold on it) has its peaks up to ≈ 25 Hz —
/// the band strong-motion processing keeps — which is the Nyquist frequency of a 50 Hz
/// channel. A slower channel loses those peaks: the bundled Landers LCN345 record (200 Hz,
/// PGA 7.7 m/s²) low-passed and decimated keeps 99 % of its PGA at 50 Hz, 84 % at 40 Hz, 55 %
/// at 20 Hz and 4 % at 1 Hz (an LN? channel); docs/stationxml.md, "Sampling rate".
pub const MIN_SAMPLE_RATE_HZ: f64 = 50.0;

/// Why a channel epoch cannot be used to calibrate and orient its data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unusable {
    #[error("no InstrumentSensitivity")]
    NoSensitivity,
    #[error("velocity channel ({units}): usable only differentiated to acceleration (acquire: [inventory] differentiate_velocity = true; monitor, replay, ims: --differentiate-velocity)")]
    Velocity { units: String },
    #[error("input units {units:?} are not an acceleration")]
    NotAcceleration { units: String },
    #[error("output units {units:?} are not counts")]
    OutputNotCounts { units: String },
    #[error("sensitivity {value} gives an absurd gain ({gain} m/s² per count)")]
    AbsurdGain { value: f64, gain: f64 },
    #[error("no {field}")]
    Missing { field: &'static str },
    #[error(
        "sampling rate {rate_hz} Hz is below the {MIN_SAMPLE_RATE_HZ} Hz minimum: the ground \
         acceleration that rocks or slides a block has peaks up to ≈ 25 Hz, the Nyquist \
         frequency of {MIN_SAMPLE_RATE_HZ} Hz; slower channels lose them (docs/stationxml.md)"
    )]
    RateTooLow { rate_hz: f64 },
    #[error("{field} = {value} is out of range ({range})")]
    OutOfRange {
        field: &'static str,
        value: f64,
        range: &'static str,
    },
}

/// A StationXML document that could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{document}: {problem}")]
pub struct InventoryError {
    /// The file or name of the document.
    pub document: String,
    pub problem: String,
}

/// Why a channel of a record cannot be calibrated from the inventory.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LookupError {
    #[error("channel {id} is not in the inventory")]
    UnknownChannel { id: String },
    #[error("channel {id}: no epoch of the inventory contains {time}")]
    NoEpoch { id: String, time: String },
    #[error("channel {id} ({document}, epoch from {start}): {reason}")]
    Unusable {
        id: String,
        document: String,
        start: String,
        reason: Unusable,
    },
    #[error(
        "channel {id}: the record's sampling rate {record_hz} Hz differs from the inventory's {inventory_hz} Hz"
    )]
    RateMismatch {
        id: String,
        record_hz: f64,
        inventory_hz: f64,
    },
}

impl Inventory {
    /// Parses one StationXML document (FDSN 1.0–1.2; UTF-8, or ISO-8859-1 when declared).
    /// `source` names it in messages.
    pub fn parse(source: &str, bytes: &[u8]) -> Result<Inventory, InventoryError> {
        stationxml::parse(source, bytes).map(|channels| Inventory { channels })
    }

    /// Reads and parses one StationXML file.
    pub fn read(path: &Path) -> Result<Inventory, InventoryError> {
        let source = path.display().to_string();
        let bytes =
            crate::bounded_read::read_bounded(path, crate::bounded_read::MAX_DATA_FILE_BYTES)
                .map_err(|e| InventoryError {
                    document: source.clone(),
                    problem: format!("cannot read: {e}"),
                })?;
        Inventory::parse(&source, &bytes)
    }

    /// Reads several files into one inventory (their epochs in the order given).
    pub fn read_all<P: AsRef<Path>>(paths: &[P]) -> Result<Inventory, InventoryError> {
        let mut all = Inventory::default();
        for path in paths {
            all.channels
                .extend(Inventory::read(path.as_ref())?.channels);
        }
        Ok(all)
    }

    /// The epoch of channel `id` (`NET.STA.LOC.CHA`) that contains `t_ns`; when several do
    /// (overlapping documents), the one that started last.
    #[must_use]
    pub fn epoch_at(&self, id: &str, t_ns: i128) -> Option<&ChannelEpoch> {
        self.channels
            .iter()
            .filter(|c| c.id() == id && c.contains(t_ns))
            .max_by_key(|c| c.start_ns.unwrap_or(i128::MIN))
    }

    /// The calibration of channel `id` for a record starting at `t_ns` sampled at
    /// `record_rate_hz`: the epoch containing `t_ns`, usable, at the same rate (within
    /// [`MAX_RATE_MISMATCH`]).
    pub fn calibration_at(
        &self,
        id: &str,
        t_ns: i128,
        record_rate_hz: f64,
    ) -> Result<Calibration, LookupError> {
        self.calibration_at_with(id, t_ns, record_rate_hz, false)
    }

    /// [`Inventory::calibration_at`], velocity channels usable (to be differentiated) when
    /// `differentiate_velocity`.
    pub fn calibration_at_with(
        &self,
        id: &str,
        t_ns: i128,
        record_rate_hz: f64,
        differentiate_velocity: bool,
    ) -> Result<Calibration, LookupError> {
        let epoch = self.epoch_at(id, t_ns).ok_or_else(|| {
            if self.channels.iter().any(|c| c.id() == id) {
                LookupError::NoEpoch {
                    id: id.to_string(),
                    time: format_utc_ns(t_ns),
                }
            } else {
                LookupError::UnknownChannel { id: id.to_string() }
            }
        })?;
        let calibration = epoch
            .calibration_with(differentiate_velocity)
            .map_err(|reason| LookupError::Unusable {
                id: id.to_string(),
                document: epoch.source.clone(),
                start: epoch.start_ns.map_or_else(|| "?".into(), format_utc_ns),
                reason,
            })?;
        let inventory_hz = calibration.sample_rate_hz;
        let within = (record_rate_hz - inventory_hz).abs() <= MAX_RATE_MISMATCH * inventory_hz;
        if !within {
            return Err(LookupError::RateMismatch {
                id: id.to_string(),
                record_hz: record_rate_hz,
                inventory_hz,
            });
        }
        Ok(calibration)
    }
}

impl ChannelEpoch {
    /// `NET.STA.LOC.CHA`.
    #[must_use]
    pub fn id(&self) -> String {
        format!(
            "{}.{}.{}.{}",
            self.network, self.station, self.location, self.channel
        )
    }

    /// Whether `t_ns` lies in `[start, end)` (a missing start is unbounded).
    #[must_use]
    pub fn contains(&self, t_ns: i128) -> bool {
        self.start_ns.is_none_or(|s| s <= t_ns) && self.end_ns.is_none_or(|e| t_ns < e)
    }

    /// The gain in m/s² per count, or why there is none: the sensitivity must take an
    /// acceleration to counts, and the gain be finite, non-zero and at most
    /// [`MAX_ABS_GAIN_MPS2_PER_COUNT`] in magnitude.
    pub fn gain_mps2_per_count(&self) -> Result<f64, Unusable> {
        self.gain_with(false).map(|(gain, _)| gain)
    }

    /// The gain and what it applies to: acceleration channels as
    /// [`ChannelEpoch::gain_mps2_per_count`]; velocity channels too when
    /// `differentiate_velocity` (gain in (m/s)/count, [`SensorInput::Velocity`]), else refused.
    pub fn gain_with(&self, differentiate_velocity: bool) -> Result<(f64, SensorInput), Unusable> {
        let s = self.sensitivity.as_ref().ok_or(Unusable::NoSensitivity)?;
        let (to_mps2, input) = match classify_unit(&s.input_units) {
            UnitKind::Acceleration { to_mps2 } => (to_mps2, SensorInput::Acceleration),
            UnitKind::Velocity { to_mps } if differentiate_velocity => {
                (to_mps, SensorInput::Velocity)
            }
            UnitKind::Velocity { .. } => {
                return Err(Unusable::Velocity {
                    units: s.input_units.clone(),
                })
            }
            _ => {
                return Err(Unusable::NotAcceleration {
                    units: s.input_units.clone(),
                })
            }
        };
        if let Some(out) = &s.output_units {
            if classify_unit(out) != UnitKind::Counts {
                return Err(Unusable::OutputNotCounts { units: out.clone() });
            }
        }
        let gain = to_mps2 / s.value;
        if !(gain.is_finite() && gain != 0.0 && gain.abs() <= MAX_ABS_GAIN_MPS2_PER_COUNT) {
            return Err(Unusable::AbsurdGain {
                value: s.value,
                gain,
            });
        }
        Ok((gain, input))
    }

    /// Everything needed to calibrate and orient this channel's data, or the first reason
    /// it cannot be: the gain ([`ChannelEpoch::gain_mps2_per_count`]), an azimuth, a dip in
    /// [−90°, 90°] and a sampling rate of at least [`MIN_SAMPLE_RATE_HZ`].
    pub fn calibration(&self) -> Result<Calibration, Unusable> {
        self.calibration_with(false)
    }

    /// [`ChannelEpoch::calibration`], velocity channels accepted (to be differentiated) when
    /// `differentiate_velocity`.
    pub fn calibration_with(&self, differentiate_velocity: bool) -> Result<Calibration, Unusable> {
        let (gain_mps2_per_count, input) = self.gain_with(differentiate_velocity)?;
        let azimuth_deg = self
            .azimuth_deg
            .ok_or(Unusable::Missing { field: "Azimuth" })?;
        let dip_deg = self.dip_deg.ok_or(Unusable::Missing { field: "Dip" })?;
        let sample_rate_hz = self.sample_rate_hz.ok_or(Unusable::Missing {
            field: "SampleRate",
        })?;
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(Unusable::OutOfRange {
                field: "SampleRate",
                value: sample_rate_hz,
                range: "> 0 Hz",
            });
        }
        if sample_rate_hz < MIN_SAMPLE_RATE_HZ {
            return Err(Unusable::RateTooLow {
                rate_hz: sample_rate_hz,
            });
        }
        let azimuth = Azimuth::from_degrees(azimuth_deg).map_err(|_| Unusable::OutOfRange {
            field: "Azimuth",
            value: azimuth_deg,
            range: "finite degrees",
        })?;
        let axis = ChannelAxis::new(azimuth, dip_deg).map_err(|_| Unusable::OutOfRange {
            field: "Dip",
            value: dip_deg,
            range: "-90 to 90 degrees",
        })?;
        Ok(Calibration {
            gain_mps2_per_count,
            input,
            axis,
            sample_rate_hz,
        })
    }
}
