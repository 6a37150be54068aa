use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = ssmctl::cli::Cli::parse();
    // SIGINT/SIGTERM/SIGHUP remove the command's staged outputs before the process exits.
    if let Err(e) = fileio::install_signal_cleanup() {
        eprintln!("error: cannot install the signal handler that removes unfinished outputs: {e}");
        return std::process::ExitCode::FAILURE;
    }
    match ssmctl::cli::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
