//! A trial's configuration: dotted keys to TOML values, and the two forms
//! the learner reads it in (a nested TOML table, `--set KEY=VALUE` flags).

use std::collections::BTreeMap;

/// A trial's configuration override: dotted `TrainConfig` key -> TOML value.
///
/// ```
/// let mut o = buridan_study::Overrides::new();
/// o.insert("ppo.lr".into(), toml::Value::Float(5e-4));
/// assert_eq!(buridan_study::overrides::to_set_args(&o), ["ppo.lr=0.0005"]);
/// ```
pub type Overrides = BTreeMap<String, toml::Value>;

/// The overrides as `KEY=VALUE` strings for `learner train --set`, values in
/// TOML inline syntax.
///
/// ```
/// let mut o = buridan_study::Overrides::new();
/// o.insert("hidden".into(), toml::Value::Array(vec![64.into(), 64.into()]));
/// o.insert("algo".into(), "ppo".into());
/// assert_eq!(buridan_study::overrides::to_set_args(&o), ["algo=\"ppo\"", "hidden=[64, 64]"]);
/// ```
pub fn to_set_args(overrides: &Overrides) -> Vec<String> {
    overrides.iter().map(|(k, v)| format!("{k}={v}")).collect()
}

/// The overrides as a nested TOML table (`ppo.lr` becomes `[ppo] lr`), ready
/// to merge into or write as a configuration file. A key that is both a value
/// and a section (`ppo = 1` and `ppo.lr`) keeps the section.
///
/// ```
/// let mut o = buridan_study::Overrides::new();
/// o.insert("ppo.lr".into(), toml::Value::Float(1e-3));
/// o.insert("agents".into(), toml::Value::Integer(4));
/// let t = buridan_study::overrides::to_table(&o);
/// assert_eq!(t["ppo"]["lr"].as_float(), Some(1e-3));
/// assert_eq!(t["agents"].as_integer(), Some(4));
/// ```
pub fn to_table(overrides: &Overrides) -> toml::Table {
    let mut table = toml::Table::new();
    for (key, value) in overrides {
        merge_key(&mut table, key, value.clone());
    }
    table
}

/// Sets dotted `key` to `value` inside `table`, creating sections on the way
/// (replacing a non-table value that stands where a section must go).
///
/// ```
/// let mut t: toml::Table = toml::from_str("[ppo]\nlr = 0.001\nepochs = 12").unwrap();
/// buridan_study::overrides::merge_key(&mut t, "ppo.lr", toml::Value::Float(3e-4));
/// assert_eq!(t["ppo"]["lr"].as_float(), Some(3e-4));
/// assert_eq!(t["ppo"]["epochs"].as_integer(), Some(12));
/// ```
pub fn merge_key(table: &mut toml::Table, key: &str, value: toml::Value) {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap_or_default();
    let mut node = table;
    for part in parts {
        let entry = node
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if !entry.is_table() {
            *entry = toml::Value::Table(toml::Table::new());
        }
        let toml::Value::Table(next) = entry else {
            return;
        };
        node = next;
    }
    match node.get(last) {
        Some(toml::Value::Table(_)) if !value.is_table() => {}
        _ => {
            node.insert(last.to_string(), value);
        }
    }
}

/// A short human form, `ppo.lr=0.0005 hidden=[64, 64]`, for tables and logs.
///
/// ```
/// let mut o = buridan_study::Overrides::new();
/// o.insert("ppo.epochs".into(), toml::Value::Integer(7));
/// assert_eq!(buridan_study::overrides::describe(&o), "ppo.epochs=7");
/// ```
pub fn describe(overrides: &Overrides) -> String {
    to_set_args(overrides).join(" ")
}
