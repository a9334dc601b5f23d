//! ROS 2 transport (ros2-client over RustDDS): the `pbr_msgs` interfaces and the node's
//! subscriptions, publishers and parameters.

pub mod msg;
