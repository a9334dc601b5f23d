"""ros2 launch file for the rockwatch node.

    ros2 launch launch-scripts/rockwatch.launch.py config:=config/node.toml state_dir:=/var/lib/rockwatch

The binary is `rockwatch` on PATH (cargo install --path .) unless `rockwatch:=/path/to/rockwatch`.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("rockwatch", default_value="rockwatch"),
        DeclareLaunchArgument("config", default_value="config/node.toml"),
        DeclareLaunchArgument("state_dir", default_value="state"),
        ExecuteProcess(
            cmd=[
                LaunchConfiguration("rockwatch"), "node",
                "--config", LaunchConfiguration("config"),
                "--state-dir", LaunchConfiguration("state_dir"),
            ],
            output="screen",
            sigterm_timeout="10",
        ),
    ])
