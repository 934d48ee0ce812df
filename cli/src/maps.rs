//! `learner maps`: the bundled reference models, the map generators, and
//! a generated map written out as a MovingAI file.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use buridan_env::generate::GeneratedMap;
use buridan_env::REFERENCE_MODELS;

/// `learner maps` arguments.
#[derive(Debug, clap::Args)]
pub struct MapsArgs {
    /// Write the map a generator spec names as MovingAI `.map` text
    /// (`FAMILY/HEIGHTxWIDTH[/KEY=VALUE...]/seed=SEED`, e.g.
    /// `maze/19x19/seed=0`; the list without it shows the families and
    /// their keys). Any command that takes a map name takes the spec too.
    #[arg(long, value_name = "SPEC")]
    pub generate: Option<GeneratedMap>,
    /// With `--generate`: the file to write (default: standard output).
    #[arg(long, requires = "generate")]
    pub out: Option<PathBuf>,
}

/// The families and keys `learner maps` lists, one line each.
const GENERATORS: &[(&str, &str)] = &[
    (
        "maze/HxW[/density=0.3][/walls=8][/straight=0.8]/seed=S",
        "walls grown as mostly straight random walks, like POGEMA's mazes",
    ),
    (
        "braid/HxW[/loops=0.5]/seed=S",
        "a perfect maze with loops knocked through (odd H and W)",
    ),
    (
        "random/HxW[/density=0.3]/seed=S",
        "random obstacles, cut-off cells walled in",
    ),
    (
        "warehouse/HxW[/shelf=10][/gap=1][/aisle=3][/margin=7][/edge=2][/missing=0]/seed=S",
        "rows of shelves (warehouse/33x46/seed=0 is POGEMA's warehouse)",
    ),
];

/// Runs `learner maps`.
pub fn run(args: &MapsArgs) -> Result<()> {
    let Some(spec) = &args.generate else {
        return list();
    };
    let text = spec.grid().to_movingai();
    match &args.out {
        Some(path) => {
            std::fs::write(path, text)
                .with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!("wrote {spec} to {}", path.display());
        }
        None => std::io::stdout().write_all(text.as_bytes())?,
    }
    Ok(())
}

fn list() -> Result<()> {
    let mut out = std::io::stdout().lock();
    for m in REFERENCE_MODELS {
        let map = m.load();
        writeln!(
            out,
            "{:8} {:>3}x{:<3} {}",
            m.id,
            map.grid.height(),
            map.grid.width(),
            m.description
        )?;
    }
    writeln!(out, "\ngenerated maps, named by their spec:")?;
    for (form, what) in GENERATORS {
        writeln!(out, "  {form}\n      {what}")?;
    }
    Ok(())
}
