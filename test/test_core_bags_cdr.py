"""com_core.bags.cdr: WrenchStamped and Header to and from their CDR bytes, checked against
an independent serializer (rosbags), at every alignment of the wrench after the frame_id,
in large mixed batches, and on malformed bytes."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from com_core.bags.cdr import (
    decode_header,
    decode_wrench,
    decode_wrench_batch,
    encode_header,
    encode_wrench_stamped,
    with_wrench,
)

TS = get_typestore(Stores.ROS2_JAZZY)
T = TS.types
WRENCH = (1.5, -2.25, 9.80665, 1e-300, -0.0, 123456.789)
# frame_ids of 0..8 characters put the wrench after 0..7 padding bytes (every alignment)
FRAMES = ["", "a", "ab", "abc", "abcd", "abcde", "abcdef", "abcdefg", "ft_sensor"]
STAMPS = [0, 1, 999_999_999, 1_000_000_000, 1_700_000_000_123_456_789, -1]


def rosbags_header(stamp_ns: int, frame_id: str):
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )


def rosbags_wrench(stamp_ns: int, frame_id: str, w) -> bytes:
    vector = T["geometry_msgs/msg/Vector3"]
    msg = T["geometry_msgs/msg/WrenchStamped"](
        header=rosbags_header(stamp_ns, frame_id),
        wrench=T["geometry_msgs/msg/Wrench"](
            force=vector(x=w[0], y=w[1], z=w[2]), torque=vector(x=w[3], y=w[4], z=w[5])
        ),
    )
    return bytes(TS.serialize_cdr(msg, "geometry_msgs/msg/WrenchStamped"))


@pytest.mark.parametrize("frame_id", FRAMES)
def test_wrench_stamped_layout_padding_and_round_trip(frame_id):
    name = len(frame_id) + 1  # with its NUL
    pad = -(12 + name) % 8  # the doubles align to 8 from the body's start (byte 4)
    for stamp in STAMPS:
        raw = encode_wrench_stamped(stamp, frame_id, WRENCH)
        assert len(raw) == 4 + 12 + name + pad + 48
        assert raw[:4] == b"\x00\x01\x00\x00"  # CDR little endian
        assert raw[16 + name : 16 + name + pad] == b"\x00" * pad
        assert raw == rosbags_wrench(stamp, frame_id, WRENCH)  # byte for byte
        stamps, wrenches, frames = decode_wrench_batch([raw])
        assert stamps.tolist() == [stamp] and frames.tolist() == [frame_id]
        assert wrenches.tobytes() == np.array([WRENCH]).tobytes()  # bit for bit, -0.0 too
        # and rosbags reads our bytes as the same message
        msg = TS.deserialize_cdr(raw, "geometry_msgs/msg/WrenchStamped")
        assert msg.header.frame_id == frame_id
        assert (msg.wrench.force.z, msg.wrench.torque.z) == (WRENCH[2], WRENCH[5])
        # one message at a time, and its wrench replaced under the same header
        one_stamp, one_frame, one = decode_wrench(raw)
        assert (one_stamp, one_frame) == (stamp, frame_id)
        assert np.array(one).tobytes() == wrenches[0].tobytes()
        other = np.arange(6.0) - 2.5
        assert with_wrench(raw, other) == rosbags_wrench(stamp, frame_id, other)


@pytest.mark.parametrize("frame_id", ["", "tare/home", "object/tilt_x-", "done", "x" * 128])
def test_header_round_trip_with_and_without_the_wire_padding(frame_id):
    for stamp in STAMPS:
        raw = encode_header(stamp, frame_id)
        assert len(raw) == 4 + 12 + len(frame_id) + 1
        assert raw == bytes(
            TS.serialize_cdr(rosbags_header(stamp, frame_id), "std_msgs/msg/Header")
        )
        assert decode_header(raw) == (stamp, frame_id)
        # on the wire a CDR payload is padded to 4 bytes: the padding is not in the label
        padded = raw + b"\x00" * (-len(raw) % 4)
        assert decode_header(padded) == (stamp, frame_id)
    assert decode_header(encode_header(5, "pose/é")) == (5, "pose/é")  # UTF-8, 2 bytes


def test_a_large_mixed_batch_decodes_in_input_order():
    """20000 messages of four frame_ids (two of one length, so one layout with two names),
    shuffled: each row is its own message's stamp, wrench and frame."""
    rng = np.random.default_rng(1)
    n = 20_000
    names = np.array(["ft_sensor", "tool0", "ft_sensoR", "a_much_longer_frame_name"])
    frame_of = rng.integers(0, len(names), n)
    stamps = rng.integers(0, 2**31 * 1_000_000_000, n)  # int32 seconds
    wrenches = rng.normal(0.0, 50.0, (n, 6))
    raws = [
        encode_wrench_stamped(int(s), str(names[k]), w)
        for s, k, w in zip(stamps, frame_of, wrenches, strict=True)
    ]
    got_stamps, got_wrenches, got_frames = decode_wrench_batch(raws)
    assert got_stamps.dtype == np.int64 and got_wrenches.shape == (n, 6)
    np.testing.assert_array_equal(got_stamps, stamps)
    np.testing.assert_array_equal(got_wrenches, wrenches)
    assert got_frames.tolist() == names[frame_of].tolist()
    # a batch of one frame_id takes the shared-name path and gives the same rows
    same = [i for i in range(n) if frame_of[i] == 0]
    one_frame = decode_wrench_batch([raws[i] for i in same])
    np.testing.assert_array_equal(one_frame[1], wrenches[same])
    assert set(one_frame[2]) == {"ft_sensor"}
    empty = decode_wrench_batch([])
    assert [a.shape for a in empty] == [(0,), (0, 6), (0,)]


def test_malformed_wrench_bytes_raise_value_error():
    raw = encode_wrench_stamped(7, "ft_sensor", WRENCH)
    for cut in (16, 26, 30, len(raw) - 8, len(raw) - 1):  # the wrench cut short
        with pytest.raises(ValueError, match=f"not a WrenchStamped: {cut} bytes"):
            decode_wrench_batch([raw[:cut]])
    too_long_name = bytearray(raw)
    struct.pack_into("<I", too_long_name, 12, 1_000_000)  # a frame_id past the end
    with pytest.raises(ValueError, match="not a WrenchStamped"):
        decode_wrench_batch([bytes(too_long_name)])
    with pytest.raises(ValueError, match="not a WrenchStamped"):  # a Header is no wrench
        decode_wrench_batch([encode_header(7, "ft_sensor")])
    # one bad message fails its batch (the node drops the batch and says so)
    with pytest.raises(ValueError):
        decode_wrench_batch([raw, raw[:40], raw])


@pytest.mark.parametrize("raw", [b"", b"\x00\x01\x00\x00", b"\x00\x01\x00\x00" + bytes(11)])
def test_bytes_too_short_for_a_header_raise_value_error(raw):
    with pytest.raises((ValueError, IndexError)):
        decode_wrench_batch([raw])
    with pytest.raises((ValueError, IndexError)):
        decode_header(raw)
