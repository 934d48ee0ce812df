//! How a study evaluates each trained policy: a name and a controller.

use std::path::Path;

use buridan_eval::by_name::{Controller, Labelled, Portfolio};
use buridan_eval::shield::DEFAULT_PATIENCE;

/// The named ways a study evaluates a policy, in the order reports list
/// them: (name, controller over the run's checkpoint; `{K}` is
/// [`DEFAULT_PATIENCE`]). `sampled` and `greedy` act as trained;
/// `shielded` is greedy through the PIBT collision shield; `fallback`
/// also lets an agent without progress for K steps follow its shortest
/// path; `settle` counts only the first arrival on a goal as progress;
/// `ordered` also fills dead-end aisles from the back; `lanes` also keeps
/// one-lane corridors one-way; `evict` also backs agents out of dead ends
/// entered in the wrong order (the shield option `evict`); `rescued`, `lookahead`, `backstop` and
/// `pace` put the shielded policy in a planner net (`rescue_planner`,
/// within `rescue_time`).
pub const NAMED_ACTIONS: [(&str, &str); 12] = [
    ("sampled", "sampled:checkpoint:"),
    ("greedy", "checkpoint:"),
    ("shielded", "shield:checkpoint:"),
    ("fallback", "shield={K}:checkpoint:"),
    ("settle", "shield-settle={K}:checkpoint:"),
    ("ordered", "shield-ordered={K}:checkpoint:"),
    ("lanes", "shield-lanes={K}:checkpoint:"),
    (
        "evict",
        "shield[patience={K},ordered,evict,lanes]:checkpoint:",
    ),
    ("rescued", "rescue:shield:checkpoint:"),
    ("lookahead", "lookahead:shield:checkpoint:"),
    ("backstop", "backstop:shield:checkpoint:"),
    ("pace", "pace:shield:checkpoint:"),
];

/// How a study evaluates each trained policy: a name (its folder and its
/// label in reports) and a [`Controller`] over the policy, whose checkpoint
/// is each run's. Written as one of [`NAMED_ACTIONS`] or as
/// `[LABEL@]CONTROLLER` with the checkpoint's DIR left out
/// (`"bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:"`;
/// the grammar of `learner eval --controller`, [`Labelled`]).
///
/// ```
/// use buridan_experiment::plan::Actions;
/// let a: Actions = "lanes".parse().unwrap();
/// assert_eq!((a.name(), a.controller().to_string().as_str()), ("lanes", "shield-lanes=16:checkpoint:"));
/// let a: Actions = "evict".parse().unwrap();
/// assert_eq!(a.controller().to_string(), "shield[patience=16,ordered,evict,lanes]:checkpoint:");
/// let a: Actions = "bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:".parse().unwrap();
/// assert_eq!(a.name(), "bss");
/// assert!("cbs".parse::<Actions>().unwrap_err().contains("evaluates no policy"));
/// assert!("sampled:checkpoint:runs/a".parse::<Actions>().unwrap_err().contains("without DIR"));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Actions {
    name: String,
    controller: Controller,
    /// Written as `LABEL@CONTROLLER` rather than by a name.
    labelled: bool,
}

impl Actions {
    /// The folder name and report label (`sampled`, `shielded`, a label).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The controller, its checkpoint left empty.
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// The controller over the policy in `run`, with `rescue_planner` in
    /// nets that name no planner.
    pub fn controller_for(&self, run: &Path, rescue_planner: Option<&Portfolio>) -> Controller {
        let c = self.controller.clone().with_checkpoint(run);
        match rescue_planner {
            Some(p) => c.with_default_planner(p),
            None => c,
        }
    }

    /// Where [`NAMED_ACTIONS`] lists it.
    pub fn named_rank(name: &str) -> Option<usize> {
        NAMED_ACTIONS.iter().position(|(n, _)| *n == name)
    }
}

impl std::str::FromStr for Actions {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        if let Some((name, form)) = NAMED_ACTIONS.iter().find(|(n, _)| *n == text) {
            let form = form.replace("{K}", &DEFAULT_PATIENCE.to_string());
            return Ok(Actions {
                name: name.to_string(),
                controller: form.parse().expect("the named actions parse"),
                labelled: false,
            });
        }
        let names: Vec<_> = NAMED_ACTIONS.iter().map(|(n, _)| *n).collect();
        let l: Labelled = text.parse().map_err(|e| {
            format!(
                "action '{text}' is neither one of {} nor [LABEL@]CONTROLLER: {e}",
                names.join(", ")
            )
        })?;
        let policies = l.controller.policies();
        if policies.is_empty() {
            return Err(format!(
                "action '{text}' evaluates no policy: its controller needs checkpoint: (without DIR: each run's)"
            ));
        }
        if policies
            .iter()
            .any(|p| !p.checkpoint.as_os_str().is_empty())
        {
            return Err(format!(
                "action '{text}': write checkpoint: without DIR (each run's checkpoint is evaluated)"
            ));
        }
        if !l.label.chars().any(|c| c.is_ascii_alphanumeric()) {
            return Err(format!(
                "action '{text}': a label needs a letter or a digit"
            ));
        }
        if Actions::named_rank(&l.label).is_some() {
            return Err(format!(
                "action '{text}': the label '{}' names one of {}; choose another",
                l.label,
                names.join(", ")
            ));
        }
        Ok(Actions {
            name: l.label,
            controller: l.controller,
            labelled: true,
        })
    }
}

impl std::fmt::Display for Actions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.labelled {
            write!(f, "{}@{}", self.name, self.controller)
        } else {
            f.write_str(&self.name)
        }
    }
}

buridan_eval::serde_as_text!(Actions);
