"""The pure tf buffer: chained lookups both ways, latest transform wins, clear refusals."""
import math
import threading

import numpy as np
from px100_control.errors import InvalidInputError
from px100_control.perception.tf_buffer import TfBuffer, transform_matrix
import pytest


def _quat_z(angle):
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


def test_chain_through_the_common_ancestor():
    """Frames base -> link1 -> link2 and base -> camera: link2 in the camera and back."""
    tf = TfBuffer()
    tf.set_transform('base', 'link1', (0.1, 0, 0), _quat_z(math.pi / 2))
    tf.set_transform('link1', 'link2', (0.2, 0, 0), _quat_z(0.0))
    tf.set_transform('/base', 'camera', (0, 0, 0.5), (1.0, 0.0, 0.0, 0.0))   # looking down
    T_base_link2 = tf.lookup('base', 'link2')
    np.testing.assert_allclose(T_base_link2[:3, 3], [0.1, 0.2, 0.0], atol=1e-12)
    T_cam_link2 = tf.lookup('camera', 'link2')
    np.testing.assert_allclose(T_cam_link2[:3, 3], [0.1, -0.2, 0.5], atol=1e-12)
    np.testing.assert_allclose(tf.lookup('link2', 'camera') @ T_cam_link2, np.eye(4),
                               atol=1e-12)
    assert tf.frames() == ['base', 'camera', 'link1', 'link2']


def test_latest_transform_replaces_the_previous_one():
    tf = TfBuffer()
    tf.set_transform('a', 'b', (1, 0, 0), (0, 0, 0, 1))
    tf.set_transform('a', 'b', (2, 0, 0), (0, 0, 0, 2))          # unnormalised is normalised
    np.testing.assert_allclose(tf.lookup('a', 'b'), transform_matrix((2, 0, 0), (0, 0, 0, 1)))


def test_unknown_or_unconnected_frames_and_bad_input_are_refused():
    tf = TfBuffer()
    tf.set_transform('a', 'b', (0, 0, 0), (0, 0, 0, 1))
    tf.set_transform('c', 'd', (0, 0, 0), (0, 0, 0, 1))
    with pytest.raises(InvalidInputError, match="no tf path from 'd' to 'a'"):
        tf.lookup('a', 'd')
    with pytest.raises(InvalidInputError, match="no tf path from 'x' to 'a'"):
        tf.lookup('a', 'x')
    with pytest.raises(InvalidInputError, match='no rotation'):
        tf.set_transform('a', 'e', (0, 0, 0), (0, 0, 0, 0))
    with pytest.raises(InvalidInputError, match='two distinct'):
        tf.set_transform('a', 'a', (0, 0, 0), (0, 0, 0, 1))
    assert np.array_equal(tf.lookup('zzz', 'zzz'), np.eye(4))


def test_wait_for_returns_once_the_transform_arrives_or_none_after_the_timeout():
    tf = TfBuffer()
    assert tf.wait_for('a', 'b', 0.05) is None
    timer = threading.Timer(0.05, tf.set_transform, ('a', 'b', (0, 0, 1), (0, 0, 0, 1)))
    timer.start()
    T = tf.wait_for('a', 'b', 5.0)
    timer.join()
    assert T is not None and T[2, 3] == 1.0


def test_add_message_stores_each_transform_and_returns_the_refused():
    """A TFMessage's good transforms are stored; a bad one (one frame name) is refused, named."""
    from types import SimpleNamespace as NS

    def stamped(parent, child, x):
        return NS(header=NS(frame_id=parent), child_frame_id=child, transform=NS(
            translation=NS(x=x, y=0.0, z=0.0), rotation=NS(x=0.0, y=0.0, z=0.0, w=1.0)))
    buf = TfBuffer()
    refused = buf.add_message(NS(transforms=[stamped('c', 'c', 0.1), stamped('a', 'b', 0.5)]))
    assert len(refused) == 1 and "'c' -> 'c'" in refused[0]
    assert buf.lookup('a', 'b')[0, 3] == pytest.approx(0.5)
