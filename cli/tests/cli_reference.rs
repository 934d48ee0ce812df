//! The book's command-line reference (`docs/src/reference/cli.md`) is the
//! `--help` of every `learner` command, so it cannot drift from clap: this
//! test renders it and compares. After changing an argument, rewrite the
//! page with `BURIDAN_BLESS=1 cargo test -p buridan-cli --test cli_reference`.
//!
//! The page is the default build's: with the dev-only `soak` feature,
//! `learner bench` has one more command, and this test stands aside.
#![cfg(not(feature = "soak"))]

use std::path::PathBuf;
use std::process::Command;

fn help(path: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_learner"))
        .args(path)
        .arg("--help")
        .env("NO_COLOR", "1")
        .env("COLUMNS", "100")
        .output()
        .unwrap();
    assert!(out.status.success(), "learner {path:?} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommands a help text lists (its `Commands:` section, without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim() != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .filter(|name| name != "help")
        .collect()
}

fn render(path: &mut Vec<String>, page: &mut String) {
    let args: Vec<&str> = path.iter().map(String::as_str).collect();
    let text = help(&args);
    let level = "#".repeat(path.len().clamp(1, 3) + 1);
    let title = if path.is_empty() {
        "learner".to_owned()
    } else {
        format!("learner {}", path.join(" "))
    };
    page.push_str(&format!(
        "{level} `{title}`\n\n```text\n{}\n```\n\n",
        text.trim_end()
    ));
    for sub in subcommands(&text) {
        path.push(sub);
        render(path, page);
        path.pop();
    }
}

#[test]
fn the_books_cli_reference_is_the_help_of_every_command() {
    let mut page = String::from(
        "# Command line (`learner`)\n\n\
         <!-- Generated from clap by cli/tests/cli_reference.rs; rewrite with\n     \
         BURIDAN_BLESS=1 cargo test -p buridan-cli --test cli_reference -->\n\n\
         Every command's `--help`. Run them as `cargo run --release -p buridan-cli \
         --bin learner -- COMMAND ...` or `target/release/learner COMMAND ...`. \
         The `actor` binary (`actor --help`) joins a `learner serve` run; see \
         [Distributed training](../guide/distributed.md). `learner bench soak` is \
         built only with the dev-only `soak` feature (`cargo build --release -p \
         buridan-cli -p buridan-actor --features buridan-cli/soak`), as that \
         guide's soak section says.\n\n",
    );
    render(&mut Vec::new(), &mut page);
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/src/reference/cli.md");
    if std::env::var_os("BURIDAN_BLESS").is_some() {
        std::fs::write(&file, &page).unwrap();
    }
    let committed = std::fs::read_to_string(&file).unwrap_or_default();
    assert!(
        committed == page,
        "{} is stale: rerun with BURIDAN_BLESS=1 cargo test -p buridan-cli --test cli_reference",
        file.display()
    );
}
