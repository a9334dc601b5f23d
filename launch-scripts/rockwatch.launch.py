"""ros2 launch file of the rockwatch node (launch_ros.actions.Node).

    ros2 launch rockwatch rockwatch.launch.py namespace:=/site_a config:=/etc/rockwatch/node.toml

(installed by the ament package `rockwatch` of launch-scripts/, see README "ROS 2 use"), or
from a checkout: ros2 launch launch-scripts/rockwatch.launch.py … with `rockwatch` installed
as that package. launch_ros starts `lib/rockwatch/rockwatch node --config CONFIG` with
`--ros-args -r __node:=rockwatch -r __ns:=NAMESPACE --params-file PARAMS -r from:=to`; the
node resolves its relative names (pbr/accel, pbr/alerts, pbr/reset, …) in NAMESPACE.

Launch arguments:
  namespace     the node's namespace (default /): its topics become NAMESPACE/pbr/…
  config        the node configuration (TOML)
  state_dir     the state directory (alert journal); empty: the configuration's
  params_file   a ROS 2 parameter file (YAML); empty: none
  alerts_topic  where pbr/alerts is remapped to (default: pbr/alerts, not remapped)
  imminent_theta_ratio  the alert threshold |θ|/α, in (0, 1] (a parameter with a descriptor);
                empty (the default): not passed, so the params file's value, else the
                configuration's ([engine.alerts]), stands

Only what the user set is passed: params_file when given, then imminent_theta_ratio when given
(after the file, so a value given on the command line wins over the file's).
"""
ARGUMENTS = [
    ("namespace", "/", "the node's namespace: its topics become NAMESPACE/pbr/..."),
    ("config", "/etc/rockwatch/node.toml", "the node configuration (TOML)"),
    ("state_dir", "", "the state directory (alert journal); empty: the configuration's"),
    ("params_file", "", "a ROS 2 parameter file (YAML); empty: none"),
    ("alerts_topic", "pbr/alerts", "where pbr/alerts is remapped to"),
    ("imminent_theta_ratio", "",
     "overturn_imminent at |theta|/alpha >= this, in (0, 1]; empty: not passed (the params "
     "file's value, else the configuration's)"),
]


def node_options(namespace, config, state_dir, params_file, alerts_topic, imminent_theta_ratio):
    """The keyword arguments of launch_ros.actions.Node for these launch arguments (strings)."""
    arguments = ["node", "--config", config]
    if state_dir:
        arguments += ["--state-dir", state_dir]
    # Only what the user set: a default here would override the params file and the
    # configuration (launch_ros passes the sources in order; the last one wins).
    parameters = [params_file] if params_file else []
    if imminent_theta_ratio:
        parameters.append({"alerts.imminent_theta_ratio": float(imminent_theta_ratio)})
    return dict(
        package="rockwatch",
        executable="rockwatch",
        name="rockwatch",
        namespace=namespace,
        arguments=arguments,
        parameters=parameters,
        remappings=[("pbr/alerts", alerts_topic)],
        output="screen",
        # SIGTERM: the node finishes the packets taken and flushes its journal.
        sigterm_timeout="10",
    )


def _node(context):
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    values = {name: LaunchConfiguration(name).perform(context) for name, _, _ in ARGUMENTS}
    return [Node(**node_options(**values))]


def generate_launch_description():
    # Imported here: the module (node_options) also loads without launch, for the tests.
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction

    return LaunchDescription(
        [DeclareLaunchArgument(name, default_value=default, description=text)
         for name, default, text in ARGUMENTS]
        + [OpaqueFunction(function=_node)]
    )
