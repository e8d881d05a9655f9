"""The rosbags typestore (ROS 2 Jazzy) with the emla_msgs types registered from their installed .msg files."""
import os
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from emla_core.errors import InputError


def msg_directory():
    """Where emla_msgs' .msg files are installed (the ament prefixes, then this Python's prefix)."""
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p] + [sys.prefix]
    for prefix in prefixes:
        candidate = Path(prefix) / 'share' / 'emla_msgs' / 'msg'
        if candidate.is_dir():
            return candidate
    raise InputError('emla_msgs is not installed (no share/emla_msgs/msg); run `make setup`')


_TYPESTORE = None


def typestore():
    """The typestore, built once per process."""
    global _TYPESTORE
    if _TYPESTORE is None:
        store = get_typestore(Stores.ROS2_JAZZY)
        types = {}
        for msg in sorted(msg_directory().glob('*.msg')):
            types.update(get_types_from_msg(msg.read_text(), f'emla_msgs/msg/{msg.stem}'))
        store.register(types)
        _TYPESTORE = store
    return _TYPESTORE
