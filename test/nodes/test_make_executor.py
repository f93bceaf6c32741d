"""make_executor: the executor every node and the client spin in, chosen by kind or env."""
from px100_control.ros.common import EXECUTOR_KINDS, make_executor
import pytest

pytestmark = pytest.mark.ros


@pytest.mark.parametrize('kind', EXECUTOR_KINDS)
def test_every_kind_spins_a_node(rclpy_context, kind):
    from rclpy.node import Node
    node = Node('executor_probe', context=rclpy_context)
    ticks = []
    node.create_timer(0.01, lambda: ticks.append(1))
    executor = make_executor(context=rclpy_context, kind=kind)
    executor.add_node(node)
    for _ in range(50):
        executor.spin_once(timeout_sec=0.05)
        if len(ticks) >= 3:
            break
    executor.shutdown()
    node.destroy_node()
    assert len(ticks) >= 3, kind


def test_unknown_kind_is_refused_with_the_choices(rclpy_context, monkeypatch):
    monkeypatch.setenv('PX100_EXECUTOR', 'turbo')
    with pytest.raises(ValueError, match='events, single, multi'):
        make_executor(context=rclpy_context)
    monkeypatch.setenv('PX100_EXECUTOR', 'Single ')       # case and blanks do not matter
    assert type(make_executor(context=rclpy_context)).__name__ == 'SingleThreadedExecutor'
