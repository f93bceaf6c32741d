#!/usr/bin/env python3
"""Print a ROS_DOMAIN_ID whose DDS ports no process on this host holds, for the test runner.

A test run in a domain shared with another ROS program (a user's bringup, another checkout's
tests) sees that program's nodes: a second driver, one viewer too many in a node list. DDS
(RTPS spec, the default port mapping of Fast DDS and Cyclone DDS) gives participant i of domain
d the unicast discovery port 7400 + 250 d + 10 + 2 i; a domain is free here when none of the
first PARTICIPANTS of those ports can be bound. Usage: ``free_domain.py [WORKERS]``: the first
of WORKERS consecutive free domains, tried in a random order within 10..89.
"""

import random
import socket
import sys

PORT_BASE, DOMAIN_GAIN, UNICAST_OFFSET, PARTICIPANT_GAIN = 7400, 250, 10, 2
#: participant indices probed per domain (one per process using the domain)
PARTICIPANTS = 12
LOWEST, HIGHEST = 10, 89


def discovery_port(domain, participant):
    """Return the unicast discovery (metatraffic) UDP port of one participant of a domain."""
    return PORT_BASE + DOMAIN_GAIN * domain + UNICAST_OFFSET + PARTICIPANT_GAIN * participant


def domain_in_use(domain):
    """Return True if a process on this host holds a discovery port of the domain."""
    for participant in range(PARTICIPANTS):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            try:
                sock.bind(('0.0.0.0', discovery_port(domain, participant)))
            except OSError:
                return True
    return False


def free_domains(workers, rng=random):
    """Return the first domain d with d .. d + workers - 1 all free, or None if there is none."""
    starts = list(range(LOWEST, HIGHEST - workers + 2))
    rng.shuffle(starts)
    for start in starts:
        if not any(domain_in_use(start + k) for k in range(workers)):
            return start
    return None


def main(argv):
    """Print the domain; exit 1 (with the reason on stderr) if every domain is taken."""
    try:
        workers = max(1, int(argv[1])) if len(argv) > 1 else 1
    except ValueError:
        print(f'free_domain: WORKERS must be a whole number, not {argv[1]!r}', file=sys.stderr)
        return 2
    domain = free_domains(workers)
    if domain is None:
        print(f'free_domain: no {workers} consecutive free DDS domains in {LOWEST}..{HIGHEST}',
              file=sys.stderr)
        return 1
    print(domain)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
