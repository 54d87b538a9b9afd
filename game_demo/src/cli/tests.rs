//! Checks of the command line as a whole: help, flag names, examples.

use clap::{CommandFactory, Parser};

use crate::Cli;

/// Every argument of every subcommand, as `path --flag`, for which `f` holds.
fn arguments(command: &clap::Command, path: &str, f: &impl Fn(&clap::Arg) -> bool, found: &mut Vec<String>) {
    for arg in command.get_arguments() {
        if !matches!(arg.get_id().as_str(), "help" | "version") && f(arg) {
            found.push(format!("{path} --{}", arg.get_long().unwrap_or(arg.get_id().as_str())));
        }
    }
    for sub in command.get_subcommands() {
        arguments(sub, &format!("{path} {}", sub.get_name()), f, found);
    }
}

/// `--help` explains every argument of every subcommand.
#[test]
fn every_argument_has_help() {
    Cli::command().debug_assert();
    let mut missing = Vec::new();
    arguments(&Cli::command(), "game_demo", &|arg| arg.get_help().is_none() && arg.get_long_help().is_none(), &mut missing);
    assert!(missing.is_empty(), "arguments without help text:\n  {}", missing.join("\n  "));
}

/// One concept, one flag: the probe grid is `--probes` (and `--cascade-probes` per cascade)
/// wherever it is taken, never `--grid` or a spacing under another name.
#[test]
fn the_same_concept_has_the_same_flag_everywhere() {
    let mut found = Vec::new();
    let retired = ["grid", "spacing", "blend", "probe-spacing", "adaptive"];
    arguments(&Cli::command(), "game_demo", &|arg| arg.get_long().is_some_and(|l| retired.contains(&l)), &mut found);
    assert!(found.is_empty(), "retired flag names: {found:?}");
}

/// Every benchmark writes its results as JSON with `--json FILE`, and every subcommand takes
/// `--trace FILE` under that one name.
#[test]
fn every_bench_takes_json_and_every_subcommand_takes_trace() {
    let command = Cli::command();
    let bench = command.find_subcommand("bench").expect("bench");
    let without: Vec<&str> =
        bench.get_subcommands().filter(|s| !s.get_arguments().any(|a| a.get_long() == Some("json"))).map(|s| s.get_name()).collect();
    assert!(without.is_empty(), "bench subcommands without --json: {without:?}");
    for args in [
        &["game_demo", "render", "--trace", "t.json"][..],
        &["game_demo", "play", "--headless", "--trace", "t.json"],
        &["game_demo", "bench", "ddgi", "--trace", "t.json"],
        &["game_demo", "bench", "trace", "--trace", "t.json"],
        &["game_demo", "bench", "walk", "--trace", "t.json"],
        &["game_demo", "bench", "classify", "--trace", "t.json"],
    ] {
        let cli = Cli::try_parse_from(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        assert_eq!(cli.trace.as_deref(), Some(std::path::Path::new("t.json")), "{args:?}");
    }
}

/// `--rest-smoothing` takes a weight or `off` (the default is on, so off must be sayable).
#[test]
fn rest_smoothing_takes_a_weight_or_off() {
    for value in ["0.9", "off", "OFF"] {
        Cli::try_parse_from(["game_demo", "eval", "--rest-smoothing", value]).unwrap_or_else(|e| panic!("{value}: {e}"));
    }
    assert_eq!(super::eval::parse_rest_smoothing("off").map(|s| s.0), Ok(None));
    assert_eq!(super::eval::parse_rest_smoothing(" 0.5 ").map(|s| s.0), Ok(Some(0.5)));
    assert!(super::eval::parse_rest_smoothing("often").is_err());
}

/// Each subcommand's long help carries examples.
#[test]
fn every_subcommand_has_examples() {
    let mut without = Vec::new();
    fn walk(command: &clap::Command, path: &str, without: &mut Vec<String>) {
        for sub in command.get_subcommands() {
            let path = format!("{path} {}", sub.get_name());
            if sub.get_subcommands().next().is_some() {
                walk(sub, &path, without);
            } else if !sub.get_after_long_help().is_some_and(|h| h.to_string().contains("Examples")) {
                without.push(path);
            }
        }
    }
    walk(&Cli::command(), "game_demo", &mut without);
    assert!(without.is_empty(), "subcommands without examples: {without:?}");
}
