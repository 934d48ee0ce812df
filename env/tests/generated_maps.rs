//! A map file wins over a generated map's spec of the same name. The only
//! test of its binary: it changes the process's working directory.

use buridan_env::Map;

#[test]
fn a_file_wins_over_a_spec_of_the_same_name() {
    let dir = std::env::temp_dir().join(format!("buridan-gen-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("random")).unwrap();
    std::fs::write(
        dir.join("random/4x4"),
        "type octile\nheight 1\nwidth 2\nmap\n..\n",
    )
    .unwrap();
    let cwd = std::env::current_dir().unwrap();
    std::env::set_current_dir(&dir).unwrap();
    let from_file = Map::load("random/4x4").map(|m| m.grid.free_cells().len());
    let generated = Map::load("random/4x4/seed=0").map(|m| m.grid.height());
    std::env::set_current_dir(cwd).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(from_file.unwrap(), 2);
    assert_eq!(generated.unwrap(), 4);
}
