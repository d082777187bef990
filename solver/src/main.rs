//! The solver's command line. Not written yet: the level-set solver is tracked in its own issue.

fn main() {
    eprintln!("the solver is not implemented yet");
    std::process::exit(2);
}
