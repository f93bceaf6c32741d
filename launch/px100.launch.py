"""
Launch the simulated arm: sim_driver, ik_service, trajectory_server, state_publisher (+ extras).

``ros2 launch px100_control px100.launch.py robot_model:=px100 robot_name:=arm1 record:=true``

Every node runs in the robot namespace ``/<robot_name>`` with the parameters of
``params_file`` (default: the package's config/nodes.yaml, which fits every robot: what depends
on the robot comes from config/robots/<robot_model>.yaml), then robot_model, robot_name and
use_sim_time from the arguments. ``use_sim_time:=true`` also makes sim_driver publish /clock
(``publish_clock``), so the nodes have a clock to follow. The camera node (simulated RGB-D
camera) runs unless ``camera:=false``. ``record:=true`` adds the recorder (the robot namespace
and /diagnostics to a bag in the working directory), ``viewer:=true`` the browser viewer.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'px100_control'


def generate_launch_description():
    """Return the launch description (arguments, the four nodes, recorder, viewer)."""
    robot_model = LaunchConfiguration('robot_model')
    robot_name = LaunchConfiguration('robot_name')
    params_file = LaunchConfiguration('params_file')
    use_sim_time = LaunchConfiguration('use_sim_time')
    arguments = [
        DeclareLaunchArgument('robot_model', default_value='px100',
                              description='robot description: config/robots/<robot_model>.yaml'),
        DeclareLaunchArgument('robot_name', default_value=robot_model,
                              description='namespace of the nodes and tf frame prefix'),
        DeclareLaunchArgument('params_file',
                              default_value=PathJoinSubstitution(
                                  [FindPackageShare(PACKAGE), 'config', 'nodes.yaml']),
                              description='ROS parameters file of the nodes (the default fits '
                                          'every robot_model)'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='follow /clock, published by sim_driver '
                                          '(publish_clock), instead of the system clock'),
        DeclareLaunchArgument('record', default_value='false',
                              description='also record the robot namespace to a bag'),
        DeclareLaunchArgument('viewer', default_value='false',
                              description='also start the browser viewer'),
        DeclareLaunchArgument('camera', default_value='true',
                              description='start the simulated RGB-D camera'),
    ]
    parameters = [params_file, {'robot_model': robot_model, 'robot_name': robot_name,
                                'use_sim_time': use_sim_time}]
    # with use_sim_time the driver owns the clock and publishes /clock for every node
    nodes = [Node(package=PACKAGE, executable='sim_driver', namespace=robot_name,
                  parameters=parameters + [{'publish_clock': use_sim_time}], output='screen')]
    nodes += [Node(package=PACKAGE, executable=exe, namespace=robot_name,
                   parameters=parameters, output='screen')
              for exe in ('ik_service', 'trajectory_server', 'state_publisher')]
    nodes.append(Node(package=PACKAGE, executable='record', namespace=robot_name,
                      parameters=parameters, output='screen',
                      condition=IfCondition(LaunchConfiguration('record'))))
    nodes.append(Node(package=PACKAGE, executable='viewer', namespace=robot_name,
                      parameters=parameters, output='screen',
                      condition=IfCondition(LaunchConfiguration('viewer'))))
    nodes.append(Node(package=PACKAGE, executable='camera', namespace=robot_name,
                      parameters=parameters, output='screen',
                      condition=IfCondition(LaunchConfiguration('camera'))))
    return LaunchDescription(arguments + nodes)
