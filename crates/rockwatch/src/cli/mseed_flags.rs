//! The MiniSEED input of `monitor` and `replay`: its flags, declared once (clap `flatten`),
//! and what they become: the StationXML inventory and the channel choice.

use std::path::PathBuf;

use rockwatch::replay::ChannelChoice;
use rockwatch_core::inventory::Inventory;

/// A station's MiniSEED file, the StationXML that calibrates it, and which channels to use.
#[derive(Debug, Clone, clap::Args)]
pub struct MseedInputFlags {
    /// MiniSEED file with the station's channels (E/N/Z or 1/2/3). Integer counts need a gain:
    /// --stationxml, or the station's gain_mps2_per_count in the node's configuration
    /// (--config); without one they are refused. Gaps inside the file are filled linearly.
    #[arg(long, value_name = "FILE")]
    pub mseed: Option<PathBuf>,
    /// StationXML documents giving each --mseed channel's gain, azimuth and dip (the epoch in
    /// force at the data's start; its sampling rate must match): counts become m/s² on
    /// east/north/up, whatever the channels are called. See docs/stationxml.md.
    #[arg(long, value_name = "FILE", num_args = 1.., requires = "mseed")]
    pub stationxml: Vec<PathBuf>,
    /// Which of the station's --mseed channels to use: a channel-code pattern (`?` one
    /// character, `*` any run), e.g. `HN?`. Default: the station's one sensor, or among several
    /// its accelerometer (instrument code N: HN?, BN?, …); several sensors and no single
    /// accelerometer is an error listing them.
    #[arg(long, value_name = "PATTERN", requires = "mseed")]
    pub channels: Option<String>,
    /// Velocity channels of --stationxml (input units M/S) are differentiated to acceleration
    /// (central differences on the sample grid, docs/stationxml.md) instead of refused.
    #[arg(long = "differentiate-velocity", requires = "stationxml")]
    pub differentiate_velocity: bool,
}

impl MseedInputFlags {
    /// The --stationxml documents read together (None without any).
    pub fn inventory(&self) -> anyhow::Result<Option<Inventory>> {
        Ok(match self.stationxml.as_slice() {
            [] => None,
            files => Some(Inventory::read_all(files)?),
        })
    }

    /// Which channels to take and whether velocity ones are differentiated.
    pub fn choice(&self) -> ChannelChoice {
        ChannelChoice {
            channels: self.channels.clone(),
            differentiate_velocity: self.differentiate_velocity,
        }
    }
}
