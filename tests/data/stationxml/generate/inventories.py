"""Writes, with ObsPy (validated against the FDSN schema), the inventories of the MiniSEED
count files in tests/data/mseed (see that directory's README for the calibration factors):

- obspy_XX.STN_k2.xml: XX.STN..HN1/2/3 of k2_STNA_HN123_counts.mseed, 250 Hz. Sensitivities
  are the inverses of the per-channel factors of ObsPy's K2 reader (g = 9.81), so the counts
  file with this inventory gives the m/s² of k2_STNA_HN123_ms2_float32.mseed. The real
  orientation of the K2 is unknown; HN1 is declared east (az 90), HN2 north (az 0), HN3 up
  (dip -90): the order the float32 file is read in without an inventory.
- obspy_BO.AKT01_knet.xml: BO.AKT01..HNE of knet_AKT013_HNE_counts.mseed, 100 Hz, sensitivity
  the inverse of 2.384185791015625e-06 (m/s²)/count (K-NET scale factor 2000 gal / 2^23).

Run from the repository root: python3 tests/data/stationxml/generate/inventories.py
"""
from obspy import UTCDateTime
from obspy.core.inventory import (Inventory, Network, Station, Channel, Response,
                                  InstrumentSensitivity)

OUT = "tests/data/stationxml/"


def channel(code, az, dip, rate, calib, lat, lon, elev, kind):
    return Channel(
        code=code, location_code="", latitude=lat, longitude=lon, elevation=elev,
        depth=0.0, azimuth=az, dip=dip, sample_rate=rate,
        start_date=UTCDateTime("1990-01-01"), types=[kind, "GEOPHYSICAL"],
        response=Response(instrument_sensitivity=InstrumentSensitivity(
            value=1.0 / calib, frequency=1.0, input_units="M/S**2",
            output_units="COUNTS")))


def write(name, net, sta, lat, lon, elev, channels):
    inv = Inventory(networks=[Network(net, stations=[Station(
        sta, lat, lon, elev, channels=channels, start_date=UTCDateTime("1990-01-01"))])],
        source="rockwatch tests/data/stationxml/generate/inventories.py")
    inv.write(OUT + name, format="STATIONXML", validate=True)


K2 = [("HN1", 90.0, 0.0, 1.1682748289245507e-06), ("HN2", 0.0, 0.0, 1.1682281943836448e-06),
      ("HN3", 0.0, -90.0, 1.1687419361571917e-06)]
write("obspy_XX.STN_k2.xml", "XX", "STN", 50.470, 4.279, 144.0,
      [channel(c, az, dip, 250.0, k, 50.470, 4.279, 144.0, "TRIGGERED") for c, az, dip, k in K2])
write("obspy_BO.AKT01_knet.xml", "BO", "AKT01", 39.6069, 140.3213, 34.0,
      [channel("HNE", 90.0, 0.0, 100.0, 2.384185791015625e-06, 39.6069, 140.3213, 34.0,
               "TRIGGERED")])
