//! The `wrench_estimator` ROS 2 node (feature `ros2`); see `tactile_force::ros::wrench_estimator`.

fn main() -> std::process::ExitCode {
    tactile_force::ros::main(
        "wrench_estimator",
        tactile_force::ros::wrench_estimator::run,
    )
}
