use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = ssmctl::cli::Cli::parse();
    match ssmctl::cli::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
