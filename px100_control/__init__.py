"""px100_control: a simulated PincherX-100 (and other arms) driven through ROS 2 Jazzy."""

__version__ = '0.1.0'
