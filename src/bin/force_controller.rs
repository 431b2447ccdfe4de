//! The `force_controller` ROS 2 node (feature `ros2`); see `tactile_force::ros::force_controller`.

fn main() -> std::process::ExitCode {
    tactile_force::ros::main(
        "force_controller",
        tactile_force::ros::force_controller::run,
    )
}
