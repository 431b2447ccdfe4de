//! The `wrench_estimator` ROS 2 node (feature `ros2`); see `tactile_force::ros::wrench_estimator`.

#[tokio::main]
async fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    match tactile_force::ros::wrench_estimator::run().await {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("wrench_estimator: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
