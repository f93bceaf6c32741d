"""
QoS between rclpy profiles and a bag's recorded profiles (rosbag2's v9 dicts).

The recorder stores what each publisher offered (:func:`qos_to_dict`) and subscribes with a QoS
every publisher matches (:func:`subscription_qos`); the replayer publishes with what was
recorded (:func:`publisher_qos`). Durations in the dicts are ``{sec, nsec}``.
"""
from typing import Sequence

from px100_control.bag import metadata as md
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile,
                       ReliabilityPolicy)

#: queue of a recorder's subscription (bursts are not dropped)
SUBSCRIPTION_DEPTH = 1000


def _duration(d) -> dict:
    return md.duration_dict(d.nanoseconds)


def _durability(latched: bool) -> DurabilityPolicy:
    return DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE


def all_latched(offered: Sequence[QoSProfile]) -> bool:
    """Return True if every offered QoS is transient local (also for none)."""
    return all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)


def qos_to_dict(qos: QoSProfile) -> dict:
    """Return a rclpy QoSProfile as rosbag2's v9 QoS dict."""
    def name(policy, value) -> str:
        try:
            return policy(value).name.lower()
        except ValueError:
            return 'unknown'
    return {
        'history': name(HistoryPolicy, qos.history), 'depth': int(qos.depth),
        'reliability': name(ReliabilityPolicy, qos.reliability),
        'durability': name(DurabilityPolicy, qos.durability),
        'deadline': _duration(qos.deadline), 'lifespan': _duration(qos.lifespan),
        'liveliness': name(LivelinessPolicy, qos.liveliness),
        'liveliness_lease_duration': _duration(qos.liveliness_lease_duration),
        'avoid_ros_namespace_conventions': bool(qos.avoid_ros_namespace_conventions),
    }


def subscription_qos(offered: Sequence[QoSProfile]) -> QoSProfile:
    """
    Return a QoS that matches every publisher (as rosbag2 adapts it).

    Reliable if all publishers are reliable, else best effort; transient local if all are,
    else volatile; a deep keep-last queue so that bursts are not dropped.
    """
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    latched = bool(offered) and all_latched(offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=SUBSCRIPTION_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=_durability(latched))


def ahead_qos(latched: bool) -> QoSProfile:
    """Return the QoS of a subscription made before any publisher exists (reliable)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=SUBSCRIPTION_DEPTH,
                      reliability=ReliabilityPolicy.RELIABLE, durability=_durability(latched))


def assumed_offer(latched: bool) -> dict:
    """Return the QoS dict recorded for a topic whose publisher is gone before it is asked."""
    return qos_to_dict(QoSProfile(depth=1 if latched else 10,
                                  reliability=ReliabilityPolicy.RELIABLE,
                                  durability=_durability(latched)))


def matches_all(mine: QoSProfile, offered: Sequence[QoSProfile]) -> bool:
    """Return True if a subscription with QoS ``mine`` matches every offered QoS."""
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    return (reliable or mine.reliability == ReliabilityPolicy.BEST_EFFORT) and \
        (all_latched(offered) or mine.durability == DurabilityPolicy.VOLATILE)


def describe(qos: QoSProfile) -> str:
    """Return 'reliable, volatile' etc. of a QoS (for log lines)."""
    return f'{qos.reliability.name.lower()}, {qos.durability.name.lower()}'


def publisher_qos(profiles: Sequence[dict]) -> QoSProfile:
    """Return the QoS to replay a topic with, from its recorded offered QoS profiles."""
    profiles = [p for p in profiles if isinstance(p, dict)]
    reliable = all(p.get('reliability', 'reliable') != 'best_effort' for p in profiles)
    latched = bool(profiles) and all(p.get('durability') == 'transient_local' for p in profiles)
    depth = max([int(p.get('depth') or 0) for p in profiles] + [0])
    if depth <= 0:
        depth = 1 if latched else 10
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=_durability(latched))
