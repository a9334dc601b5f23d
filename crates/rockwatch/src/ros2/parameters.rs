//! The node's ROS 2 parameters: the run-time settings (alert thresholds, state interval),
//! their declaration with initial values, their validation, and the hand-over of a change to
//! the node's event loop.

use std::sync::{Arc, Mutex};

use ros2_client::{NodeOptions, ParameterValue};

use crate::ports::ControlSender;
use rockwatch_core::engine::{AlertConfig, EngineConfig};

/// ROS 2 parameter names of the run-time settings (all doubles).
pub const PARAM_IMMINENT_THETA_RATIO: &str = "alerts.imminent_theta_ratio";
pub const PARAM_IMMINENT_PROBABILITY: &str = "alerts.imminent_probability";
pub const PARAM_QUIET_THRESHOLD_MPS2: &str = "alerts.quiet_threshold_mps2";
pub const PARAM_QUIET_S: &str = "alerts.quiet_s";
pub const PARAM_STATE_INTERVAL_S: &str = "state_interval_s";

/// `options` with the parameter services started and the parameters declared (initial values
/// from `engine`); a valid change is applied and handed to `controls` (the node's event loop).
pub(super) fn with_parameters(
    options: NodeOptions,
    engine: &EngineConfig,
    controls: ControlSender,
) -> NodeOptions {
    let alerts = Arc::new(Mutex::new(engine.alerts));
    options
        .start_parameter_services(true)
        .declare_parameter(
            PARAM_IMMINENT_THETA_RATIO,
            ParameterValue::Double(engine.alerts.imminent_theta_ratio),
        )
        .declare_parameter(
            PARAM_IMMINENT_PROBABILITY,
            ParameterValue::Double(engine.alerts.imminent_probability),
        )
        .declare_parameter(
            PARAM_QUIET_THRESHOLD_MPS2,
            ParameterValue::Double(engine.alerts.quiet_threshold_mps2),
        )
        .declare_parameter(PARAM_QUIET_S, ParameterValue::Double(engine.alerts.quiet_s))
        .declare_parameter(
            PARAM_STATE_INTERVAL_S,
            ParameterValue::Double(engine.state_interval_s),
        )
        .parameter_validator(Box::new(|name, value| {
            if name.starts_with("alerts.") || name == PARAM_STATE_INTERVAL_S {
                validate_parameter(name, value)
            } else {
                Ok(())
            }
        }))
        .parameter_set_action(Box::new(move |name, value| {
            apply_parameter(name, value, &alerts, &controls)
        }))
}

/// Checks a parameter value: finite, > 0 (probabilities ≤ 1).
fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
    let v = parameter_f64(value).ok_or_else(|| format!("{name} must be a double"))?;
    let ok = match name {
        PARAM_IMMINENT_PROBABILITY => v > 0.0 && v <= 1.0,
        _ => v.is_finite() && v > 0.0,
    };
    if ok {
        Ok(())
    } else {
        Err(format!("{name}: invalid value {v}"))
    }
}

fn parameter_f64(value: &ParameterValue) -> Option<f64> {
    match value {
        ParameterValue::Double(v) => Some(*v),
        ParameterValue::Integer(v) => Some(*v as f64),
        _ => None,
    }
}

/// Applies a parameter to the alert configuration and hands the change to the node's event
/// loop (effective before its next packet).
fn apply_parameter(
    name: &str,
    value: &ParameterValue,
    alerts: &Mutex<AlertConfig>,
    controls: &ControlSender,
) -> Result<(), String> {
    validate_parameter(name, value)?;
    let v = parameter_f64(value).ok_or_else(|| format!("{name} must be a double"))?;
    if name == PARAM_STATE_INTERVAL_S {
        controls.set_state_interval_s(v);
        return Ok(());
    }
    let mut config = alerts
        .lock()
        .map_err(|_| "alert configuration lock poisoned".to_string())?;
    match name {
        PARAM_IMMINENT_THETA_RATIO => config.imminent_theta_ratio = v,
        PARAM_IMMINENT_PROBABILITY => config.imminent_probability = v,
        PARAM_QUIET_THRESHOLD_MPS2 => config.quiet_threshold_mps2 = v,
        PARAM_QUIET_S => config.quiet_s = v,
        // Built-in parameters such as use_sim_time.
        _ => return Ok(()),
    }
    controls.set_alert_config(*config);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_update_alert_thresholds_and_reject_bad_values() {
        assert!(
            validate_parameter(PARAM_IMMINENT_THETA_RATIO, &ParameterValue::Double(0.5)).is_ok()
        );
        assert!(
            validate_parameter(PARAM_IMMINENT_PROBABILITY, &ParameterValue::Double(1.5)).is_err()
        );
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::Double(f64::NAN)).is_err());
        assert!(validate_parameter(PARAM_STATE_INTERVAL_S, &ParameterValue::Double(-1.0)).is_err());
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::Integer(5)).is_ok());
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::String("5".into())).is_err());
    }
}
