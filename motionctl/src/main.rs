fn main() -> std::process::ExitCode {
    motionctl::cli::main()
}
