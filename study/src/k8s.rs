//! Kubernetes Indexed Job manifests: one trial per completion index, every
//! pod writing its trial's run directory to one shared volume, so a cluster
//! runs many trials at once and the study aggregates them afterwards.
//!
//! The pod learns its index from `JOB_COMPLETION_INDEX`, which Kubernetes
//! sets in Indexed mode; `{index}` in the arguments becomes
//! `$(JOB_COMPLETION_INDEX)`, which the kubelet expands.

use serde::{Deserialize, Serialize};

/// An Indexed Job running `completions` trials, `parallelism` at a time.
///
/// ```
/// let job = buridan_study::k8s::IndexedJob::new(
///     "tune-ppo-rm-2-1",
///     "buridan/learner:dev",
///     vec!["tune".into(), "trial".into(), "/study".into(), "--index={index}".into()],
///     40,
/// );
/// let yaml = job.to_yaml().unwrap();
/// assert!(yaml.contains("completionMode: Indexed"));
/// assert!(yaml.contains("--index=$(JOB_COMPLETION_INDEX)"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IndexedJob {
    /// Job name (a DNS-1123 label: lowercase letters, digits, `-`, at most 63).
    pub name: String,
    /// Namespace, or the current one.
    pub namespace: Option<String>,
    /// Container image with the trial runner (e.g. the learner image).
    pub image: String,
    /// Container arguments; `{index}` stands for the completion index.
    pub args: Vec<String>,
    /// Trials (indices `0..completions`).
    pub completions: u32,
    /// Pods at once.
    pub parallelism: u32,
    /// Retries of one index before it counts as failed.
    pub backoff_limit_per_index: u32,
    /// PersistentVolumeClaim of the shared results volume (ReadWriteMany
    /// when pods may land on several nodes).
    pub volume_claim: String,
    /// Where the volume is mounted in the pod.
    pub mount_path: String,
    /// CPU request and limit per pod, e.g. `"2"`.
    pub cpu: String,
    /// Memory request and limit per pod, e.g. `"2Gi"`.
    pub memory: String,
}

/// A manifest that cannot be generated, with the field at fault.
///
/// ```
/// let mut job = buridan_study::k8s::IndexedJob::new("Bad_Name", "img", vec![], 1);
/// assert_eq!(job.to_yaml().unwrap_err().field, "name");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("Indexed Job field `{field}`: {problem}")]
pub struct ManifestError {
    /// The field.
    pub field: &'static str,
    /// What is wrong.
    pub problem: String,
}

impl IndexedJob {
    /// A job with defaults: parallelism = completions, one retry per index,
    /// claim `buridan-study`, mounted at `/study`, 1 CPU and 2 GiB per pod.
    ///
    /// ```
    /// let job = buridan_study::k8s::IndexedJob::new("t", "img", vec![], 8);
    /// assert_eq!((job.parallelism, job.mount_path.as_str()), (8, "/study"));
    /// ```
    pub fn new(name: &str, image: &str, args: Vec<String>, completions: u32) -> IndexedJob {
        IndexedJob {
            name: name.to_string(),
            namespace: None,
            image: image.to_string(),
            args,
            completions,
            parallelism: completions,
            backoff_limit_per_index: 1,
            volume_claim: "buridan-study".to_string(),
            mount_path: "/study".to_string(),
            cpu: "1".to_string(),
            memory: "2Gi".to_string(),
        }
    }

    fn check(&self) -> Result<(), ManifestError> {
        let bad = |field, problem: &str| {
            Err(ManifestError {
                field,
                problem: problem.to_string(),
            })
        };
        let dns = |s: &str| {
            !s.is_empty()
                && s.len() <= 63
                && s.bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
                && !s.starts_with('-')
                && !s.ends_with('-')
        };
        if !dns(&self.name) {
            return bad(
                "name",
                "must be a DNS-1123 label (a-z, 0-9, '-', at most 63)",
            );
        }
        if let Some(ns) = &self.namespace {
            if !dns(ns) {
                return bad("namespace", "must be a DNS-1123 label");
            }
        }
        if !dns(&self.volume_claim) {
            return bad("volume_claim", "must be a DNS-1123 name");
        }
        if self.image.trim().is_empty() {
            return bad("image", "is empty");
        }
        if self.completions == 0 {
            return bad("completions", "must be at least 1");
        }
        if self.parallelism == 0 {
            return bad("parallelism", "must be at least 1");
        }
        if !self.mount_path.starts_with('/') {
            return bad("mount_path", "must be absolute");
        }
        Ok(())
    }

    /// The manifest as YAML (all strings double-quoted, so any argument is safe).
    ///
    /// ```
    /// let yaml = buridan_study::k8s::IndexedJob::new("t", "img", vec!["a: b".into()], 2).to_yaml().unwrap();
    /// assert!(yaml.contains("- \"a: b\""));
    /// ```
    pub fn to_yaml(&self) -> Result<String, ManifestError> {
        self.check()?;
        let q = |s: &str| serde_json::to_string(s).unwrap_or_default();
        let labels = |indent: &str| {
            format!("{indent}app.kubernetes.io/name: \"buridan\"\n{indent}app.kubernetes.io/component: \"study-trial\"\n")
        };
        let mut y = String::new();
        y.push_str("apiVersion: batch/v1\nkind: Job\nmetadata:\n");
        y.push_str(&format!("  name: {}\n", q(&self.name)));
        if let Some(ns) = &self.namespace {
            y.push_str(&format!("  namespace: {}\n", q(ns)));
        }
        y.push_str("  labels:\n");
        y.push_str(&labels("    "));
        y.push_str("spec:\n  completionMode: Indexed\n");
        y.push_str(&format!("  completions: {}\n", self.completions));
        y.push_str(&format!(
            "  parallelism: {}\n",
            self.parallelism.min(self.completions)
        ));
        y.push_str(&format!(
            "  backoffLimitPerIndex: {}\n",
            self.backoff_limit_per_index
        ));
        y.push_str("  template:\n    metadata:\n      labels:\n");
        y.push_str(&labels("        "));
        y.push_str("    spec:\n      restartPolicy: Never\n");
        y.push_str("      securityContext:\n        runAsNonRoot: true\n        runAsUser: 65532\n        runAsGroup: 65532\n        fsGroup: 65532\n");
        y.push_str("      containers:\n        - name: \"trial\"\n");
        y.push_str(&format!("          image: {}\n", q(&self.image)));
        y.push_str("          imagePullPolicy: \"IfNotPresent\"\n");
        y.push_str("          args:\n");
        for a in &self.args {
            y.push_str(&format!(
                "            - {}\n",
                q(&a.replace("{index}", "$(JOB_COMPLETION_INDEX)"))
            ));
        }
        y.push_str(
            "          env:\n            - name: \"NO_COLOR\"\n              value: \"1\"\n",
        );
        y.push_str("          resources:\n");
        for section in ["requests", "limits"] {
            y.push_str(&format!("            {section}:\n"));
            y.push_str(&format!("              cpu: {}\n", q(&self.cpu)));
            y.push_str(&format!("              memory: {}\n", q(&self.memory)));
        }
        y.push_str("          volumeMounts:\n            - name: \"results\"\n");
        y.push_str(&format!(
            "              mountPath: {}\n",
            q(&self.mount_path)
        ));
        y.push_str(
            "      volumes:\n        - name: \"results\"\n          persistentVolumeClaim:\n",
        );
        y.push_str(&format!(
            "            claimName: {}\n",
            q(&self.volume_claim)
        ));
        Ok(y)
    }
}
