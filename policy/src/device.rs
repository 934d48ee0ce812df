//! Where a policy's weights and a learner's tensors live: the host's cores
//! or one CUDA GPU.
//!
//! A [`DeviceSpec`] is the value a user names (`--device cuda:1`, TOML
//! `device = "cuda"`); [`DeviceSpec::open`] turns it into candle's
//! [`Device`]. CUDA needs a binary built with the `cuda` cargo feature
//! (`scripts/build-cuda.sh`); a default build refuses `cuda` with an error
//! that says so, never by falling back to the CPU behind the user's back.
//! Actors always act on the CPU: only the learner's update moves to a GPU.

use std::fmt;
use std::str::FromStr;

use candle_core::Device;

use crate::PolicyError;

/// A device by name: `cpu`, or `cuda` / `cuda:N` (GPU ordinal `N`, 0 by
/// default). One parser ([`FromStr`]) and one printer ([`fmt::Display`]);
/// TOML and JSON hold the printed form.
///
/// ```
/// use buridan_policy::DeviceSpec;
/// assert_eq!("cpu".parse::<DeviceSpec>().unwrap(), DeviceSpec::Cpu);
/// assert_eq!("cuda".parse::<DeviceSpec>().unwrap(), DeviceSpec::Cuda(0));
/// assert_eq!("cuda:1".parse::<DeviceSpec>().unwrap().to_string(), "cuda:1");
/// assert_eq!(DeviceSpec::Cuda(0).to_string(), "cuda:0");
/// assert!("gpu".parse::<DeviceSpec>().is_err());
/// assert!("cuda:x".parse::<DeviceSpec>().is_err());
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum DeviceSpec {
    /// The host's cores (the default, and the only device of a default build).
    #[default]
    Cpu,
    /// CUDA GPU with this ordinal.
    Cuda(usize),
}

/// A device name that is neither `cpu` nor `cuda[:N]`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown device '{0}': expected cpu, cuda or cuda:N (N a GPU ordinal)")]
pub struct BadDevice(pub String);

impl FromStr for DeviceSpec {
    type Err = BadDevice;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || BadDevice(s.to_string());
        match s.trim() {
            "cpu" => Ok(Self::Cpu),
            "cuda" => Ok(Self::Cuda(0)),
            other => other
                .strip_prefix("cuda:")
                .and_then(|n| n.parse().ok())
                .map(Self::Cuda)
                .ok_or_else(bad),
        }
    }
}

impl fmt::Display for DeviceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cpu => f.write_str("cpu"),
            Self::Cuda(n) => write!(f, "cuda:{n}"),
        }
    }
}

buridan_env::serde_as_text!(DeviceSpec);

/// Whether this binary was built with candle's CUDA backend (the `cuda`
/// cargo feature).
pub const CUDA_BUILT: bool = cfg!(feature = "cuda");

impl DeviceSpec {
    /// Whether this names the CPU.
    pub fn is_cpu(&self) -> bool {
        matches!(self, Self::Cpu)
    }

    /// Opens the device: the CPU always; a GPU only in a `cuda` build and
    /// where the driver finds one with that ordinal.
    ///
    /// ```
    /// use buridan_policy::{DeviceSpec, PolicyError};
    /// assert!(DeviceSpec::Cpu.open().unwrap().is_cpu());
    /// if !buridan_policy::device::CUDA_BUILT {
    ///     let err = DeviceSpec::Cuda(0).open().unwrap_err();
    ///     assert!(matches!(err, PolicyError::CudaNotBuilt { .. }));
    ///     assert!(err.to_string().contains("scripts/build-cuda.sh"));
    /// }
    /// ```
    pub fn open(&self) -> Result<Device, PolicyError> {
        match *self {
            Self::Cpu => Ok(Device::Cpu),
            Self::Cuda(ordinal) if !CUDA_BUILT => Err(PolicyError::CudaNotBuilt { ordinal }),
            Self::Cuda(ordinal) => {
                Device::new_cuda(ordinal).map_err(|e| PolicyError::DeviceUnavailable {
                    device: self.to_string(),
                    message: e.to_string(),
                })
            }
        }
    }

    /// The first CUDA device, where this binary and this machine have one
    /// (parity tests and benches run on it where it exists and say so
    /// where not).
    pub fn first_gpu() -> Option<Device> {
        Self::Cuda(0).open().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spec_prints_what_parses_back() {
        for spec in [DeviceSpec::Cpu, DeviceSpec::Cuda(0), DeviceSpec::Cuda(7)] {
            assert_eq!(spec.to_string().parse::<DeviceSpec>().unwrap(), spec);
        }
    }

    #[test]
    fn malformed_names_are_errors_that_quote_them() {
        for bad in ["", "CPU", "cuda:", "cuda:-1", "cuda:1:2", "metal", "cuda0"] {
            let err = bad.parse::<DeviceSpec>().unwrap_err();
            assert!(err.to_string().contains(&format!("'{bad}'")), "{err}");
        }
    }

    #[test]
    fn toml_holds_the_printed_form() {
        #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
        struct Cfg {
            device: DeviceSpec,
        }
        let text = "device = \"cuda:2\"\n";
        let cfg: Cfg = toml_like(text);
        assert_eq!(cfg.device, DeviceSpec::Cuda(2));
        let json = serde_json::to_string(&cfg).unwrap();
        assert_eq!(json, r#"{"device":"cuda:2"}"#);
        let err = serde_json::from_str::<Cfg>(r#"{"device":"tpu"}"#).unwrap_err();
        assert!(err.to_string().contains("unknown device 'tpu'"), "{err}");
    }

    /// The policy crate has no TOML parser; its JSON twin reads the same value.
    fn toml_like<T: serde::de::DeserializeOwned>(text: &str) -> T {
        let (key, value) = text.trim().split_once(" = ").unwrap();
        serde_json::from_str(&format!("{{\"{key}\": {value}}}")).unwrap()
    }
}
