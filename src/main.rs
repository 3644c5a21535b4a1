//! `multifield`: see [`multifield::cli`].

fn main() -> std::process::ExitCode {
    multifield::cli::main()
}
