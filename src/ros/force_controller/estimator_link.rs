//! The estimator's parameter services, as the calibration uses them: the
//! model file it estimates with, asked and then set (real ROS build only).

use std::time::Duration;

use r2r::rcl_interfaces::msg::{
    Parameter as ParameterMsg, ParameterType, ParameterValue as ValueMsg,
};
use r2r::rcl_interfaces::srv::{GetParameters, SetParameters};
use r2r::QosProfile;

use crate::ros::RosError;

/// How long the estimator's parameter service may take to answer.
const ESTIMATOR_TIMEOUT: Duration = Duration::from_secs(10);

/// The estimator's parameter services: its model file, asked and set.
pub struct EstimatorLink {
    name: String,
    get: r2r::Client<GetParameters::Service>,
    set: r2r::Client<SetParameters::Service>,
}

impl EstimatorLink {
    /// Clients of the parameter services of the node `name`.
    pub fn new(node: &mut r2r::Node, name: &str) -> Result<Self, RosError> {
        let qos = QosProfile::default;
        Ok(EstimatorLink {
            name: name.to_string(),
            get: node.create_client(&format!("{name}/get_parameters"), qos())?,
            set: node.create_client(&format!("{name}/set_parameters"), qos())?,
        })
    }

    /// The estimator's node name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The estimator's `model_file`: the model file it estimates with.
    pub async fn model_file(&self) -> Result<String, String> {
        let req = GetParameters::Request {
            names: vec!["model_file".into()],
        };
        let answer = self.call(self.get.request(&req)).await?;
        match answer.values.first() {
            Some(v) if v.type_ == ParameterType::PARAMETER_STRING as u8 => {
                Ok(v.string_value.clone())
            }
            _ => Err(format!("{} has no model_file parameter", self.name)),
        }
    }

    /// Sets the estimator's `model_file`: (taken, its answer).
    pub async fn set_model_file(&self, path: &str) -> Result<(bool, String), String> {
        let req = SetParameters::Request {
            parameters: vec![ParameterMsg {
                name: "model_file".into(),
                value: ValueMsg {
                    type_: ParameterType::PARAMETER_STRING as u8,
                    string_value: path.into(),
                    ..Default::default()
                },
            }],
        };
        let answer = self.call(self.set.request(&req)).await?;
        let r = answer.results.first().ok_or("no answer")?;
        Ok((r.successful, r.reason.clone()))
    }

    async fn call<T>(
        &self,
        request: r2r::Result<impl std::future::Future<Output = r2r::Result<T>>>,
    ) -> Result<T, String> {
        let failed = |e: String| format!("{}'s parameter service: {e}", self.name);
        let answer = request.map_err(|e| failed(e.to_string()))?;
        tokio::time::timeout(ESTIMATOR_TIMEOUT, answer)
            .await
            .map_err(|_| failed(format!("no answer within {ESTIMATOR_TIMEOUT:?}")))?
            .map_err(|e| failed(e.to_string()))
    }
}
