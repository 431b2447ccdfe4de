//! The `sim_robot` ROS 2 node (feature `ros2`); see `tactile_force::ros::sim_robot`.

fn main() -> std::process::ExitCode {
    tactile_force::ros::main("sim_robot", tactile_force::ros::sim_robot::run)
}
