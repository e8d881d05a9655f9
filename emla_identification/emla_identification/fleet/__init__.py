"""Trends of identified parameters over many recordings (a fleet of actuators, or one run for months): every
recording identified as `emla identify` does, in parallel on dask.distributed, in time order, with the changes
of each parameter (a CUSUM) and one table row per recording.

    trend(paths, ...)            the whole: a Trend with .recordings, .changes, .failed, .table (pyarrow)
    identify_recording(path)     one recording, as a Dask worker runs it (plain data in and out)
    find_recordings(paths)       files, directories and globs to recordings (expand_paths: the globs' matches)
    recording_time(path, how)    the time a recording is placed at: its first sample's, its file's modification
                                 time, a column of absolute time, or a date in its name (trend's time_from)
    detect_changes(recordings)   the CUSUM on each parameter's series
    recordings_table, table_recordings, read_table, write_table   the table (Parquet or CSV) and back
"""
from .changes import detect_changes
from .recordings import expand_paths, find_recordings, identify_recording, recording_time
from .run import ClusterLost, Trend, trend
from .table import read_table, recordings_table, table_recordings, write_table

__all__ = ['ClusterLost', 'Trend', 'detect_changes', 'expand_paths', 'find_recordings', 'identify_recording',
           'read_table', 'recording_time', 'recordings_table', 'table_recordings', 'trend', 'write_table']
