//! Runs one training from a TOML config plus `key=value` overrides and
//! prints a line per update.
//!
//! ```text
//! cargo run --release -p buridan-learner --example train_run -- OUT_DIR [config.toml] [key=value ...]
//! # e.g.
//! cargo run --release -p buridan-learner --example train_run -- /tmp/r11 \
//!     map=rm-1.1 agents=2 starts=fixed mode=ctde algo=ppo steps=200000
//! ```
//! Values are TOML (`hidden=[32,32]`, `ppo.lr=5e-4`, `lstm=true`).

use std::path::PathBuf;

use buridan_learner::train::{train, MetricsRow, Progress, Summary, TrainConfig};

struct Lines {
    every: u64,
}

impl Progress for Lines {
    fn on_update(&mut self, r: &MetricsRow) {
        let every = self.every.max(1);
        if r.update / every * every == r.update {
            println!(
                "update {:>5} steps {:>9} {:>7.1}s {:>7.0} st/s | return {:>6.3} success {:>5.3} len {:>6.2} | loss {:>8.4} pi {:>8.4} vf {:>8.4} ent {:>6.3} kl {:>7.4} β {:>6.3} |g| {:>6.2} learn {:.2}s",
                r.update,
                r.env_steps,
                r.wall_seconds,
                r.steps_per_s,
                r.episode_return_mean,
                r.success_rate,
                r.episode_len_mean,
                r.total_loss,
                r.policy_loss,
                r.vf_loss,
                r.entropy,
                r.kl,
                r.kl_coeff,
                r.grad_norm,
                r.learn_seconds
            );
        }
    }
    fn on_finish(&mut self, s: &Summary) {
        println!("{}", serde_json::to_string_pretty(s).unwrap());
    }
}

fn main() -> anyhow::Result<()> {
    buridan_policy::threads::pin_threads(1);
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .init();
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(
        args.next()
            .expect("usage: train_run OUT [config.toml] [k=v ...]"),
    );
    let mut table: toml::Table = toml::Table::new();
    let mut every = 1;
    for a in args {
        if let Some((k, v)) = a.split_once('=') {
            if k == "print_every" {
                every = v.parse()?;
                continue;
            }
            let value: toml::Value = match toml::from_str::<toml::Table>(&format!("x = {v}")) {
                Ok(t) => t["x"].clone(),
                Err(_) => toml::Value::String(v.to_string()),
            };
            let mut t = &mut table;
            let parts: Vec<&str> = k.split('.').collect();
            for p in &parts[..parts.len() - 1] {
                t = t
                    .entry(p.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                    .as_table_mut()
                    .expect("table");
            }
            t.insert(parts[parts.len() - 1].to_string(), value);
        } else {
            let text = std::fs::read_to_string(&a)?;
            table = toml::from_str(&text)?;
        }
    }
    let cfg: TrainConfig = toml::Value::Table(table).try_into()?;
    cfg.validate()?;
    println!("{}", cfg.to_toml());
    train(&cfg, &out, &mut Lines { every })?;
    Ok(())
}
