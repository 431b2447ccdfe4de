//! The `sim_robot` ROS 2 node (feature `ros2`); see `tactile_force::ros::sim_robot`.

#[tokio::main]
async fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    match tactile_force::ros::sim_robot::run().await {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sim_robot: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
