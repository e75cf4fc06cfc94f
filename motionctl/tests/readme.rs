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
