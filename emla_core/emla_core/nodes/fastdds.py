"""The suite's Fast DDS profile (fastdds.xml beside this module; why each setting: there) given to the
participants a process creates."""
import os
from pathlib import Path

FASTDDS_PROFILES = Path(__file__).with_name('fastdds.xml')  # the suite's Fast DDS defaults (why: see there)


def use_fastdds_profiles():
    """Give the Fast DDS participants this process creates the suite's defaults (FASTDDS_PROFILES), unless a
    profiles file is set already; before rclpy.init."""
    if not (os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE') or os.environ.get('FASTDDS_DEFAULT_PROFILES_FILE')):
        os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(FASTDDS_PROFILES)
