//! What the project's command-line programs share: how a bad command line is refused.

/// The command line parsed into `A`: help and version exit as clap prints them; any other
/// error is its first line with a pointer to `--help`, on stderr, and exit code 2, before
/// anything runs.
pub fn parse_args<A: clap::Parser>() -> A {
    A::try_parse().unwrap_or_else(|e| {
        use clap::error::ErrorKind;
        if matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        ) {
            e.exit()
        }
        let text = e.to_string();
        let first = text.lines().next().unwrap_or("error: bad arguments");
        eprintln!("{first} (see --help)");
        std::process::exit(2)
    })
}
