//! The repository README's error-code tables are the ones `motion::protocol::markdown_table`
//! renders from the code.

const BEGIN: &str = "<!-- codes:begin (generated from motion::protocol::markdown_table) -->\n";
const END: &str = "<!-- codes:end -->";

#[test]
fn readme_error_tables_match_the_code() {
    let readme = include_str!("../../README.md");
    let mut rendered = String::new();
    motion::protocol::markdown_table(&mut rendered).unwrap();
    let start = readme.find(BEGIN).expect("README has the codes:begin marker") + BEGIN.len();
    let end = readme.find(END).expect("README has the codes:end marker");
    if readme[start..end].trim() != rendered.trim() {
        panic!("README.md's error-code tables are out of date; put this between the markers:\n{rendered}");
    }
}

const MACHINE_BEGIN: &str = "<!-- machine:begin (generated from motion::machine::markdown) -->\n";
const MACHINE_END: &str = "<!-- machine:end -->";

#[test]
fn readme_machine_states_and_faults_match_the_code() {
    let readme = include_str!("../../README.md");
    let mut rendered = String::new();
    motion::machine::markdown(&mut rendered).unwrap();
    let start = readme.find(MACHINE_BEGIN).expect("README has the machine:begin marker")
        + MACHINE_BEGIN.len();
    let end = readme.find(MACHINE_END).expect("README has the machine:end marker");
    if readme[start..end].trim() != rendered.trim() {
        panic!(
            "README.md's machine tables are out of date; put this between the markers:\n{rendered}"
        );
    }
}

/// Every `motionctl ...` line in the READMEs' code blocks parses with today's flags (what a user
/// copies from them must not meet "unexpected argument"). Usage lines with placeholders in
/// brackets or alternatives are skipped; an output line (the transcript after a `$` command) is
/// not a command.
#[test]
fn readme_command_lines_parse() {
    use clap::Parser;
    let mut checked = 0;
    for (name, text) in [
        ("README.md", include_str!("../../README.md")),
        ("motionctl/README.md", include_str!("../README.md")),
    ] {
        let mut in_code = false;
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                in_code = !in_code;
                continue;
            }
            let cmd = line.trim_start().trim_start_matches("$ ");
            if !in_code || !cmd.starts_with("motionctl ") {
                continue;
            }
            let cmd = cmd.split(" #").next().unwrap_or(cmd).trim();
            if cmd.contains(['[', '|', '<', '>']) || cmd.contains("...") || cmd.ends_with('\\') {
                continue;
            }
            let words: Vec<&str> = cmd.split_whitespace().collect();
            if let Err(e) = motionctl::cli::Cli::try_parse_from(&words) {
                if e.kind() != clap::error::ErrorKind::DisplayHelp {
                    panic!("{name}:{}: `{cmd}`: {e}", n + 1);
                }
            }
            checked += 1;
        }
    }
    assert!(checked > 20, "only {checked} command lines found");
}

const WORDS_BEGIN: &str =
    "<!-- gcode-words:begin (generated from motion_gcode::table::markdown) -->\n";
const WORDS_END: &str = "<!-- gcode-words:end -->";

#[test]
fn readme_gcode_words_match_the_interpreter_table() {
    let readme = include_str!("../../README.md");
    let rendered = motion_gcode::table::markdown();
    let start = readme.find(WORDS_BEGIN).expect("README has the gcode-words:begin marker")
        + WORDS_BEGIN.len();
    let end = readme.find(WORDS_END).expect("README has the gcode-words:end marker");
    if readme[start..end].trim() != rendered.trim() {
        panic!("README.md's G-code word table is out of date; put this between the markers:\n{rendered}");
    }
}
