//! `learner maps`: the bundled reference models, the map generators, and
//! a generated map written out as a MovingAI file.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result};
use buridan_env::generate::{Family, GeneratedMap};
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

/// What each generator family draws, in [`Family::defaults`]' order
/// (`learner maps` lists each family's form beside it).
const ABOUT: [&str; 4] = [
    "walls grown as mostly straight random walks, like POGEMA's mazes",
    "a perfect maze with loops knocked through (odd H and W)",
    "random obstacles, cut-off cells walled in",
    "rows of shelves (warehouse/33x46/seed=0 is POGEMA's warehouse)",
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
    for (family, about) in Family::defaults().iter().zip(ABOUT) {
        writeln!(out, "  {}\n      {about}", family.form())?;
    }
    Ok(())
}
