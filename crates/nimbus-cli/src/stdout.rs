//! Standard output that a closed pipe does not turn into a panic
//! (`nimbus optics dsd --json | head`): as ripgrep does, nimbus stops
//! quietly, with success, when the reader has gone; any other write error
//! is reported once and ends the process with status 1. `outln!` and `out!`
//! replace `println!` and `print!` throughout the tool.

/// Ends the process after a failed write to standard output.
pub fn write_failed(error: std::io::Error) -> ! {
    if error.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("nimbus: error: cannot write to standard output: {error}");
    std::process::exit(1);
}

/// `println!` to standard output, ending quietly on a closed pipe.
macro_rules! outln {
    () => {
        outln!("")
    };
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(error) = writeln!(std::io::stdout().lock(), $($arg)*) {
            $crate::stdout::write_failed(error);
        }
    }};
}

/// `print!` to standard output, ending quietly on a closed pipe.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(error) = write!(std::io::stdout().lock(), $($arg)*) {
            $crate::stdout::write_failed(error);
        }
    }};
}
