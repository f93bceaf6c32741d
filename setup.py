"""ament_python package definition for px100_control."""
from glob import glob
import os

from px100_control.entry_points import TARGETS
from setuptools import find_packages, setup

PACKAGE = 'px100_control'

# Executables resolved by `ros2 run px100_control <name>` (lib/px100_control/<name>): the names
# of px100_control/entry_points.py (its TARGETS: name -> module:main), each started through it
EXECUTABLES = sorted(TARGETS)


def _data(pattern):
    return [f for f in glob(pattern) if os.path.isfile(f)]


setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/urdf', _data('urdf/*')),
        ('share/' + PACKAGE + '/config', _data('config/*.yaml')),
        ('share/' + PACKAGE + '/config/robots', _data('config/robots/*')),
        ('share/' + PACKAGE + '/config/scenes', _data('config/scenes/*')),
        ('share/' + PACKAGE + '/examples', _data('examples/*')),
        ('share/' + PACKAGE + '/launch', _data('launch/*.launch.*')),
        # environment hooks (ROS_DISTRO), registered for colcon in colcon.pkg
        ('share/' + PACKAGE + '/environment', _data('environment/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='px100_control developers',
    maintainer_email='px100-control@example.org',
    description='Simulated PincherX-100 with IK, trajectories, PID driver, '
                'Interbotix-compatible client and MCAP bags.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [f'{name} = px100_control.entry_points:{name}'
                            for name in EXECUTABLES],
    },
)
