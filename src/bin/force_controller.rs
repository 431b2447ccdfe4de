//! The `force_controller` ROS 2 node (feature `ros2`); see `tactile_force::ros::force_controller`.

#[tokio::main]
async fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    match tactile_force::ros::force_controller::run().await {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("force_controller: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
