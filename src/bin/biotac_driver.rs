//! The `biotac_driver` ROS 2 node (feature `ros2`); see `tactile_force::ros::biotac_driver`.

fn main() -> std::process::ExitCode {
    tactile_force::ros::main("biotac_driver", tactile_force::ros::biotac_driver::run)
}
