"""rosbag2 directories (metadata.yaml + zstd-chunked MCAP splits) of the suite's topics.

schema   the rosbags typestore with emla_msgs registered (message definitions, type hashes, CDR decoding)
writer   BagWriter (crash-safe splits) and write_recording
reader   read_bag: whole signals, parameter estimates and metadata of a bag; iter_messages, iter_serialized,
         bag_topics; corrupt chunks skipped with a warning (CorruptChunk) or refused where they leave a gap
chunks   iter_chunks: the same signals in parts with bounded memory (compiled SampleFrame decoding)
"""
from .chunks import iter_chunks
from .reader import BagContents, CorruptChunk, bag_topics, iter_messages, iter_serialized, read_bag
from .schema import typestore
from .writer import BagWriter, write_recording

__all__ = ['BagContents', 'BagWriter', 'CorruptChunk', 'bag_topics', 'iter_chunks', 'iter_messages', 'iter_serialized',
           'read_bag', 'typestore', 'write_recording']
