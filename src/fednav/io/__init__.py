"""Readers for real sensor data: fednav's plain CSV layout, NaveGo ``.mat`` structs, PX4
ULog, KF-GINS and gnss-ins-sim folders, ROS bags, RTKLIB, NMEA and u-blox logs.

Everything is converted at the boundary into fednav's frames and units (see
``docs/conventions.md`` and ``docs/data-formats.md``): body right-forward-up, ENU
velocities, heading from north toward east, SI units.  A bad file raises
:class:`DataError` with one line naming the file and the field.
"""

from .csvdata import read_gnss_csv, read_imu_csv, read_reference_csv, read_velocity_csv
from .data import DataError, GnssData, ImuData, ImuErrors, Reference, VelocityData
from .gnss_ins_sim import GnssInsSimRecording, read_gnss_ins_sim
from .kfgins import read_kfgins_gnss, read_kfgins_imu, read_kfgins_nav, write_kfgins_nav
from .navego import (
    FRD_TO_RFU,
    navego_euler_to_fednav,
    read_navego_gnss,
    read_navego_imu,
    read_navego_reference,
    read_navego_visual,
)
from .nmea import read_nmea
from .rinex import Ephemerides, RinexObs, read_raw_gnss, read_rinex_nav, read_rinex_obs
from .rosbag import BagRecording, read_rosbag
from .rtklib import read_rtklib_pos
from .sensorfile import SensorData, read_sensor_csv, write_sensor_csv
from .ubx import read_ubx, read_ubx_imu, read_ubx_odometer
from .ubx_raw import read_ubx_raw_gnss
from .ulog import UlogRecording, read_ulog

__all__ = [
    "DataError", "FRD_TO_RFU", "GnssData", "ImuData", "ImuErrors", "Reference",
    "VelocityData", "navego_euler_to_fednav", "read_gnss_csv", "read_imu_csv",
    "read_navego_gnss", "read_navego_imu", "read_navego_reference", "read_navego_visual",
    "read_nmea", "read_reference_csv", "read_rtklib_pos", "read_sensor_csv", "read_velocity_csv",
    "SensorData", "read_ubx", "read_ubx_imu", "read_ubx_odometer",
    "write_sensor_csv", "UlogRecording", "read_ulog",
    "BagRecording", "read_rosbag",
    "Ephemerides", "RinexObs", "read_rinex_nav", "read_rinex_obs", "read_raw_gnss",
    "read_ubx_raw_gnss",
    "GnssInsSimRecording", "read_gnss_ins_sim",
    "read_kfgins_gnss", "read_kfgins_imu", "read_kfgins_nav", "write_kfgins_nav",
]
