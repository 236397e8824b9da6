"""rosbag2 (MCAP) bags without ROS: CDR decoding of the hot messages, a reader that also
reads a copy cut short, and the crash-safe writer (docs/bag_writer.md). Depends on the
wire contract alone.
"""

from com_core.bags.cdr import (
    decode_header,
    decode_wrench,
    decode_wrench_batch,
    decode_wrenches,
    encode_header,
    encode_wrench_stamped,
    with_wrench,
)
from com_core.bags.reader import (
    INCOMPLETE_TEXT,
    RECORDER_LOST_KEY,
    BagReading,
    read_metadata,
    read_raw,
    recorder_lost,
)
from com_core.bags.writer import (
    BagWriteError,
    CrashSafeBagWriter,
)

__all__ = [
    "INCOMPLETE_TEXT",
    "RECORDER_LOST_KEY",
    "BagReading",
    "BagWriteError",
    "CrashSafeBagWriter",
    "decode_header",
    "decode_wrench",
    "decode_wrench_batch",
    "decode_wrenches",
    "encode_header",
    "encode_wrench_stamped",
    "read_metadata",
    "read_raw",
    "recorder_lost",
    "with_wrench",
]
