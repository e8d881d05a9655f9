"""rosbag2 directories (metadata.yaml + zstd-chunked MCAP splits) of the suite's topics.

schema   the rosbags typestore with emla_msgs registered (message definitions, type hashes, CDR decoding)
writer   BagWriter (crash-safe splits) and write_recording
reader   read_bag: whole signals, parameter estimates and metadata of a bag; iter_messages, iter_serialized,
         bag_topics, bag_info (metadata.yaml checked); corrupt chunks skipped with a warning (CorruptChunk) that
         the data they cost follow, or refused where they leave a gap
report   read_warnings: those warnings collected for a command's JSON
chunks   iter_chunks: the same signals in parts with bounded memory (compiled SampleFrame decoding)
"""
from emla_core.exports import lazy_exports

_EXPORTS = {'iter_chunks': 'chunks', 'typestore': 'schema', 'BagWriter': 'writer', 'write_recording': 'writer',
            **dict.fromkeys(('BagContents', 'CorruptChunk', 'bag_info', 'bag_topics', 'iter_messages',
                             'iter_serialized', 'read_bag'), 'reader'), 'read_warnings': 'report'}

__all__ = ['BagContents', 'BagWriter', 'CorruptChunk', 'bag_info', 'bag_topics', 'iter_chunks', 'iter_messages',
           'iter_serialized', 'read_bag', 'read_warnings', 'typestore', 'write_recording']
# loaded on first use: the recorder writes bags without loading the compiled reader (numba)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
