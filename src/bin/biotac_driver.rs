//! The `biotac_driver` ROS 2 node (feature `ros2`); see `tactile_force::ros::biotac_driver`.

#[tokio::main]
async fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    match tactile_force::ros::biotac_driver::run().await {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("biotac_driver: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
