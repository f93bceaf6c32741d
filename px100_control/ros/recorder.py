"""
Record in-process from Python (the client and the demos record their runs with it).

A :class:`~px100_control.ros.recorder_node.RecorderNode` spun in its own executor thread::

    from px100_control.ros.recorder import Recorder

    with Recorder('/tmp/my_run', robot_name='px100'):      # all topics of /px100 + /diagnostics
        ...                                                 # drive the robot
    # Recorder(out, all_topics=True): every topic of the graph
    # or: rec = Recorder(out, topics=['joint_states']).start(); ...; rec.stop()

    stop = record_in_process(node.context, '/tmp/my_run')  # on an existing rclpy context
    ...; stop()

``Recorder`` runs its node in its own rclpy context unless one is given; ``with Recorder(dir):``
enters only when its recorder is ready (see :mod:`px100_control.ros.recorder_node`); ``stop()``
closes the bag and returns its metadata.yaml path. Options are those of the node. Times in the
bag are the reception times (ns since the epoch).
"""
import os
import threading
from typing import Optional, Sequence

from px100_control.ros.common import BAG_EXECUTOR, make_executor, spin_once
from px100_control.ros.recorder_node import RecorderNode
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions


class Recorder:
    """
    Record in-process from Python: a RecorderNode spun in its own thread.

    :param output_dir: bag directory to create
    :param topics: topics to record (None: all of /<robot_name>/ and /diagnostics)
    :param all_topics: record every topic of the graph (with topics: in addition to them)
    :param robot_only: with all_topics, only the robot's namespace and /diagnostics
    :param robot_name: namespace of the robot's topics (and the recorder node)
    :param robot_model: robot model (URDF for /tf)
    :param context: an initialised rclpy Context to join (default: a private one)
    :param options: further RecorderNode options (duration, max_messages, write_tf, ...)
    """

    def __init__(self, output_dir: str, topics: Optional[Sequence[str]] = None,
                 all_topics: bool = False, robot_name: str = 'px100',
                 robot_model: str = 'px100', context=None, robot_only: Optional[bool] = None,
                 **options):
        self.output_dir = os.path.abspath(output_dir)
        self._args = dict(output=self.output_dir, topics=topics,
                          all_topics=all_topics or not topics,
                          robot_only=(not all_topics) if robot_only is None else robot_only,
                          **options)
        self._params = [rclpy.parameter.Parameter('robot_name', value=robot_name),
                        rclpy.parameter.Parameter('robot_model', value=robot_model)]
        self._given_context = context
        self.context = None
        self.node: Optional[RecorderNode] = None
        self._executor = None
        self._thread: Optional[threading.Thread] = None
        self.metadata_path = ''

    def start(self, wait: bool = True) -> 'Recorder':
        """
        Create the node and start recording; return self.

        :param wait: return only once the recorder is ready (subscribed and matched, see the
            module docstring; at most ready_timeout + 5 s), else at once (see wait_ready)
        """
        if self.node is not None:
            return self
        if self._given_context is None:
            self.context = rclpy.Context()
            # no rclpy signal handlers: Ctrl-C reaches the script (KeyboardInterrupt, or the
            # client's handler), and the with-block closes the bag on this context
            rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        else:
            self.context = self._given_context
        try:
            self.node = RecorderNode(context=self.context, parameter_overrides=self._params,
                                     **self._args)
        except Exception:
            if self._given_context is None:
                self.context.try_shutdown()
            raise
        self._executor = make_executor(context=self.context, kind=BAG_EXECUTOR)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name='px100_recorder', daemon=True)
        self._thread.start()
        if wait:
            self.wait_ready(self.node.ready_timeout + 5.0)
        return self

    def _spin(self) -> None:
        try:
            while self.context.ok() and not self.node.closed.is_set():
                spin_once(self._executor, 0.1)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass
        except Exception as exc:  # keep the bag: it is closed in stop()
            self.node.get_logger().error(f'recorder executor stopped: {exc}')

    def wait_ready(self, timeout: Optional[float] = None) -> bool:
        """Wait until the recorder is subscribed and matched (module docstring); True if so."""
        return self.node is not None and self.node.ready.wait(timeout)

    @property
    def finished(self) -> bool:
        """Return True once the bag is closed (stop() or a stop condition)."""
        return self.node is not None and self.node.closed.is_set()

    def wait(self, timeout: Optional[float] = None) -> bool:
        """Wait until a stop condition closed the bag; return True if it did."""
        return self.node is not None and self.node.closed.wait(timeout)

    def stop(self) -> str:
        """Close the bag, stop the node (and the private context); return metadata.yaml path."""
        if self.node is None:
            return self.metadata_path
        self.metadata_path = self.node.finish()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._executor.remove_node(self.node)
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self._given_context is None:
            self.context.try_shutdown()
        self.node = None
        return self.metadata_path

    __call__ = stop

    def __enter__(self):
        """Start recording; return once the recorder is ready (at most ready_timeout + 5 s)."""
        return self.start(wait=True)

    def __exit__(self, *exc):
        """Stop recording and close the bag."""
        self.stop()


def record_in_process(context, output_dir: str, topics: Optional[Sequence[str]] = None,
                      robot_name: str = 'px100', **options) -> Recorder:
    """
    Start recording on an existing rclpy context; return the Recorder (call it to stop).

    Example: ``stop = record_in_process(node.context, '/tmp/run'); ...; stop()``
    """
    return Recorder(output_dir, topics=topics, robot_name=robot_name, context=context,
                    **options).start()
