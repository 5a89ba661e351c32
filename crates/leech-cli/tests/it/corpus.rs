//! Issue 15's adversarial corpus: a few hundred hostile command lines across
//! every command, run in parallel, every failing case reported at once.
//!
//! The cases are `tests/data/corpus/cases.txt` (its header gives the syntax)
//! plus cases made here: the built-in robot with each numeric key set to an
//! extreme value, and files too big to commit. The rules every case is held
//! to:
//!
//! - **No panic**: not exit 101, no `panicked` on standard error, not ended
//!   by a signal (an abort, or the 4 GiB address-space limit every run gets
//!   so that an unbounded read of `/dev/zero` fails here instead of taking
//!   the machine's memory).
//! - **No hang**: the run ends within its own `--time-limit` plus
//!   [`TIME_LIMIT_SLACK_S`], or
//!   within [`DEFAULT_BOUND_S`] for a command without one (a hang guard, not
//!   a speed test: a case is killed at its bound and fails).
//! - **The expected exit class**: 0 done, 1 anything else, 2 bad input, 3 a
//!   computation that failed or did not finish.
//! - **Exit 2**: standard error is one line `leech: ...` of at most
//!   [`MAX_LINE`] characters with no control character, NUL, byte-order mark
//!   or invisible formatting character, which
//!   - names the field: a `--flag`, a key spelled with `_`, `.` or `[`
//!     (`tube.element_length_m`, `lengths[1]`), a backquoted key, the
//!     FIELD of the house format `FIELD: got VALUE, expected ALLOWED` (or
//!     `FIELD: 'VALUE' ...`, `FIELD: PATH ...`), clap's `<NAME>` of a
//!     positional argument; or, strictly, the case's `field=`. Paths are
//!     taken out first, so that a file's name does not pass for a key;
//!   - quotes the value: `got ...`, a quoted or backquoted excerpt, one of
//!     the case's own arguments verbatim, or the case's `value=`; a missing field has none, and says `not provided`,
//!     `missing`, `needed` or `give` instead;
//!   - says what is allowed: one of [`ALLOWED`]'s words, or a `<VALUE>`
//!     placeholder for a missing flag.
//! - **Exit 3**: the last line of standard error says the status (`not
//!   converged`, `time limit`, `failed`, `unreachable`, `no plan`,
//!   `impossible`), and for a solve its `residual` and `iteration`s; a time
//!   limit says what was done by a count of `iterations`, `points`, `steps`,
//!   `strides`, `shapes` or `s` simulated.
//! - **Exit 1**: one short clean line as for exit 2, without Rust's debug
//!   text (`Error(`, ` { `).

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Bound on a run of a command without `--time-limit` (s): a hang guard,
/// far above any case's time on a loaded machine (the slowest, a
/// calibration on 100 000 points, takes about 2 s alone and was killed at
/// an earlier 5 s bound while a build shared the two cores).
const DEFAULT_BOUND_S: f64 = 60.0;
/// Slack on a command's own `--time-limit` (s): the limit is checked
/// between solves, and a loaded machine delays the check and the exit.
const TIME_LIMIT_SLACK_S: f64 = 5.0;
/// Longest one-line message (characters).
const MAX_LINE: usize = 300;
/// Cases run at once: the whole corpus in well under a minute on 2 cores.
const THREADS: usize = 3;

/// One command line and what it must do.
struct Case {
    /// Where it came from (`cases.txt:12`, `robot mutation`).
    origin: String,
    /// Exit codes allowed.
    expect: Vec<i32>,
    field: Option<String>,
    value: Option<String>,
    /// Hang guard (s).
    bound: f64,
    /// Needs a flag the agreed interface adds (`--time-limit` on more commands).
    new_flag: bool,
    /// One of issue 15's reproductions.
    issue: bool,
    args: Vec<OsString>,
}

impl Case {
    fn command_line(&self) -> String {
        let args: Vec<String> = self.args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
        format!("leech {}", args.join(" "))
    }
}

/// Where the cases' files live: the committed fixtures and this run's scratch.
struct Places {
    data: PathBuf,
    tmp: PathBuf,
    robot: String,
}

impl Places {
    /// One argument with its placeholders filled in.
    fn arg(&self, word: &str) -> OsString {
        match word {
            "{empty}" => return OsString::new(),
            // Not UTF-8.
            "{bin}" => return OsString::from_vec(vec![0xff, 0xfe, b'1']),
            _ => {}
        }
        if let Some(edit) = word.strip_prefix("{robot:").and_then(|w| w.strip_suffix('}')) {
            return self.robot_file(edit).into_os_string();
        }
        let text = word
            .replace("{tmp}", self.tmp.to_str().expect("a UTF-8 temporary directory"))
            .replace("{data}", self.data.to_str().expect("a UTF-8 source tree"))
            .replace("{sp}", " ");
        OsString::from(text)
    }

    /// The built-in robot with `key=VALUE` applied: the line of `key` set to
    /// VALUE (`-` removes it), or `+TEXT` appended.
    fn robot_file(&self, edit: &str) -> PathBuf {
        let edit = edit.replace("{sp}", " ").replace("\\n", "\n");
        let text = match edit.strip_prefix('+') {
            Some(extra) => format!("{}\n{extra}\n", self.robot),
            None => {
                let (key, value) = edit.split_once('=').expect("{robot:key=value}");
                let mut found = false;
                let lines: Vec<String> = self
                    .robot
                    .lines()
                    .filter_map(|l| match l.split_whitespace().next() == Some(key) && !found {
                        true if value == "-" => {
                            found = true;
                            None
                        }
                        true => {
                            found = true;
                            Some(format!("{key} = {value}"))
                        }
                        false => Some(l.to_string()),
                    })
                    .collect();
                assert!(found, "no key {key} in the built-in robot");
                lines.join("\n")
            }
        };
        let name: String =
            edit.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '-' }).take(60).collect();
        let path = self.tmp.join(format!("robot-{name}-{:x}.toml", hash(&text)));
        std::fs::write(&path, text).unwrap();
        path
    }
}

/// A file name's distinguishing part (FNV-1a).
fn hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
}

/// Reads `cases.txt`: `EXPECT [key=value ...] | ARGS...`.
fn parse(text: &str, places: &Places) -> Vec<Case> {
    let mut cases = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (head, args) = line.split_once('|').unwrap_or_else(|| panic!("cases.txt:{}: no '|'", n + 1));
        let mut words = head.split_whitespace();
        let expect = words.next().unwrap_or_else(|| panic!("cases.txt:{}: no exit code", n + 1));
        let mut case = Case {
            origin: format!("cases.txt:{}", n + 1),
            expect: match expect {
                "*" => vec![0, 1, 2, 3],
                codes => codes.split('/').map(|c| c.parse().expect("an exit code")).collect(),
            },
            field: None,
            value: None,
            bound: DEFAULT_BOUND_S,
            new_flag: false,
            issue: false,
            args: args.split_whitespace().map(|w| places.arg(w)).collect(),
        };
        for word in words {
            match word.split_once('=') {
                Some(("field", f)) => case.field = Some(f.replace("{sp}", " ")),
                Some(("value", v)) => case.value = Some(v.replace("{sp}", " ")),
                Some(("bound", b)) => case.bound = b.parse().expect("a bound in s"),
                None if word == "new" => case.new_flag = true,
                None if word == "issue" => case.issue = true,
                _ => panic!("cases.txt:{}: unknown option {word}", n + 1),
            }
        }
        case.bound = time_limit(&case.args).map_or(case.bound, |s| s + TIME_LIMIT_SLACK_S);
        cases.push(case);
    }
    cases
}

/// The case's own `--time-limit`, if it gives a usable one.
fn time_limit(args: &[OsString]) -> Option<f64> {
    let at = args.iter().position(|a| a == "--time-limit")?;
    let seconds: f64 = args.get(at + 1)?.to_str()?.parse().ok()?;
    (seconds.is_finite() && seconds > 0.0 && seconds < 30.0).then_some(seconds)
}

/// Cases made here: the built-in robot with each numeric key set to an
/// extreme value (four per key, rotating through the list), under a command
/// chosen in turn; and inputs too big to commit.
fn generated(places: &Places) -> Vec<Case> {
    const VALUES: [&str; 12] =
        ["nan", "inf", "-inf", "-1", "0", "-0.0", "1e308", "1e-320", "\"x\"", "true", "[]", "1e5"];
    let commands: [&[&str]; 4] = [
        &["shape", "--lengths", "0.2,0.18", "--time-limit", "2"],
        &["robot", "--json"],
        &["shape", "--lengths", "0.12,0.3", "--model", "both", "--time-limit", "2"],
        &["shape3d", "--lengths", "0.2,0.18,0.16", "--time-limit", "2"],
    ];
    let keys: Vec<String> = places
        .robot
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .filter_map(|l| {
            let (key, value) = l.split_once(" = ")?;
            let value = value.split('#').next()?.trim();
            value.parse::<f64>().is_ok().then(|| key.trim().to_string())
        })
        .collect();
    let mut cases = Vec::new();
    for (i, key) in keys.iter().enumerate() {
        for k in 0..4 {
            let value = VALUES[(i * 3 + k) % VALUES.len()];
            let mut args: Vec<OsString> = commands[(i + k) % commands.len()].iter().map(OsString::from).collect();
            args.push("--robot".into());
            args.push(places.robot_file(&format!("{key}={value}")).into_os_string());
            cases.push(Case {
                origin: format!("robot mutation {key} = {value}"),
                expect: vec![0, 2, 3],
                field: None,
                value: None,
                bound: time_limit(&args).map_or(DEFAULT_BOUND_S, |s| s + TIME_LIMIT_SLACK_S),
                new_flag: false,
                issue: false,
                args,
            });
        }
    }
    cases
}

/// Files the cases name under `{tmp}`: too big to commit, or not files at all.
fn scratch_files(tmp: &Path) {
    let write = |name: &str, bytes: &[u8]| std::fs::write(tmp.join(name), bytes).unwrap();
    let brackets = "[".repeat(10_000);
    write("brackets.toml", brackets.as_bytes());
    write("bom.toml", "\u{feff}name = \"bom\"\n".as_bytes());
    write("nul.toml", b"name = \"a\0b\"\n[tube\0]\n");
    write("binary.toml", &(0..=255u8).cycle().take(4096).collect::<Vec<u8>>());
    write("long-line.toml", format!("name = \"{}\"\n", "x".repeat(1 << 20)).as_bytes());
    write("long-key.toml", format!("{} = 1\n", "k".repeat(100_000)).as_bytes());
    write("brackets.csv", format!("tube_length_m,base_angle_deg,x_m,y_m\n{brackets}\n").as_bytes());
    write("binary.csv", &(0..=255u8).rev().cycle().take(4096).collect::<Vec<u8>>());
    write("bom.csv", "\u{feff}shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n".as_bytes());
    // Issue 15: 1e5 distinct shape names took compare 32 s.
    let mut names = String::from("shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n");
    for i in 0..100_000 {
        names.push_str(&format!("S{i},0.2,0.18,90,a,0.01,0.02\n"));
    }
    write("names.csv", names.as_bytes());
    // Many rows of one shape.
    let mut rows = String::from("shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n");
    for i in 0..200_000 {
        rows.push_str(&format!("S,0.2,0.18,90,{},0.01,{}\n", if i % 2 == 0 { "a" } else { "b" }, i as f64 * 1e-6));
    }
    write("rows.csv", rows.as_bytes());
    let mut sag = String::from("tube_length_m,base_angle_deg,x_m,y_m\n");
    for i in 0..100_000 {
        sag.push_str(&format!("{},0,0.05,-0.001\n", 0.05 + (i % 250) as f64 * 1e-3));
    }
    write("sag-many.csv", sag.as_bytes());
    std::fs::create_dir_all(tmp.join("dir")).unwrap();
    // Two: one read, one written, so that no case feeds another.
    let fifo = Command::new("mkfifo").arg(tmp.join("fifo")).arg(tmp.join("fifo-out")).status().expect("mkfifo runs");
    assert!(fifo.success(), "mkfifo failed");
}

/// How a bounded run ended: its status (none if killed at the bound) and output.
struct Ended {
    status: Option<std::process::ExitStatus>,
    stdout: Vec<u8>,
    stderr: String,
}

/// Runs leech with `args` in `dir`, killed after `bound` seconds; `tag`
/// names its output files.
fn run_bounded(args: &[OsString], dir: &Path, bound: f64, tag: &str) -> Ended {
    let (out_path, err_path) = (dir.join(format!("{tag}.stdout")), dir.join(format!("{tag}.stderr")));
    // exec keeps the pid: a kill at the bound reaches leech itself.
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 4194304 2>/dev/null; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_leech"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .expect("sh starts");
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if started.elapsed().as_secs_f64() > bound {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let stdout = std::fs::read(&out_path).unwrap_or_default();
    let stderr = String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    std::fs::remove_file(&out_path).ok();
    std::fs::remove_file(&err_path).ok();
    Ended { status, stdout, stderr }
}

/// What went wrong with one run, or nothing.
fn run(case: &Case, tmp: &Path, index: usize) -> Option<String> {
    let Ended { status, stderr, .. } = run_bounded(&case.args, tmp, case.bound, &index.to_string());
    let Some(status) = status else {
        return Some(format!("hang: still running after {} s, killed", case.bound));
    };
    let Some(code) = status.code() else {
        return Some(format!("signal: ended by {status}; stderr {}", excerpt(&stderr)));
    };
    if code == 101 || stderr.contains("panicked") {
        return Some(format!("panic: exit {code}; stderr {}", excerpt(&stderr)));
    }
    if case.new_flag && stderr.contains("unexpected argument '--") {
        return Some(format!("new flag: not accepted yet: stderr {}", excerpt(&stderr)));
    }
    if !case.expect.contains(&code) {
        return Some(format!("exit {code}, expected {:?}: stderr {}", case.expect, excerpt(&stderr)));
    }
    let verdict = match code {
        1 => one_clean_line(&stderr, tmp).and_then(no_debug_text),
        2 => one_clean_line(&stderr, tmp).and_then(|line| names_field_value_allowed(line, case, tmp)),
        3 => says_status(&stderr),
        _ => Ok(()),
    };
    verdict.err().map(|why| format!("{why}: {}", excerpt(&stderr)))
}

/// A message for a report: its first 200 characters, escaped.
fn excerpt(text: &str) -> String {
    let clipped: String = text.chars().take(200).collect();
    format!("{clipped:?}{}", if text.chars().count() > 200 { "..." } else { "" })
}

/// `stderr` as one clean line; its length is counted with this run's
/// scratch directory as `{tmp}` (as long as the machine's temporary
/// directory).
fn one_clean_line<'a>(stderr: &'a str, tmp: &Path) -> Result<&'a str, String> {
    let line = stderr.strip_suffix('\n').ok_or("message: not one line ending in a newline")?;
    if line.contains('\n') {
        return Err(format!("message: {} lines, expected one", line.lines().count()));
    }
    if !line.starts_with("leech: ") {
        return Err("message: does not start with 'leech: '".into());
    }
    let length = line.replace(tmp.to_str().unwrap_or("{tmp}"), "{tmp}").chars().count();
    if length > MAX_LINE {
        return Err(format!("message: {length} characters, at most {MAX_LINE}"));
    }
    let invisible = |c: char| {
        c.is_control()
            || matches!(c, '\u{feff}' | '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2060}'..='\u{2069}')
    };
    if line.chars().any(invisible) {
        return Err("message: control or invisible characters".into());
    }
    Ok(line)
}

fn no_debug_text(line: &str) -> Result<(), String> {
    match line.contains("Error(") || line.contains(" { ") {
        true => Err("message: Rust debug text".into()),
        false => Ok(()),
    }
}

fn names_field_value_allowed(line: &str, case: &Case, tmp: &Path) -> Result<(), String> {
    // Paths out: a scratch file's name must not pass for a key.
    let text: String = line
        .trim_start_matches("leech: ")
        .replace(tmp.to_str().unwrap_or("{tmp}"), "/tmp")
        .split(' ')
        .map(|w| if w.trim_start_matches(['\'', '"']).starts_with('/') { "FILE" } else { w })
        .collect::<Vec<_>>()
        .join(" ");
    let text = text.as_str();
    let given = |w: &&OsString| w.len() > 1 && !w.to_string_lossy().starts_with("--");
    let field = match &case.field {
        Some(f) => text.contains(f.as_str()),
        // The house format `FIELD: got VALUE, expected ALLOWED` names its field.
        None => {
            text.contains("--")
                || text.contains('`')
                || (text.contains('<') && text.contains('>'))
                || [": got ", ": '", ": FILE"]
                    .iter()
                    .any(|s| text.split(s).next().is_some_and(|f| f != text && !f.is_empty()))
                || text.split(|c: char| c.is_whitespace() || c == ':').any(key_like)
        }
    };
    if !field {
        let wanted = case.field.as_ref().map(|f| format!(" ({f})")).unwrap_or_default();
        return Err(format!("message: names no field{wanted}"));
    }
    // A missing field's value is its absence.
    let value = match &case.value {
        Some(v) => text.contains(v.as_str()),
        None => {
            ["got ", "'", "`", "\"", "not provided", "missing", "needed", "give "].iter().any(|w| text.contains(w))
                || case.args.iter().filter(given).any(|a| line.contains(a.to_string_lossy().as_ref()))
        }
    };
    if !value {
        let wanted = case.value.as_ref().map(|v| format!(" ({v})")).unwrap_or_default();
        return Err(format!("message: quotes no value{wanted}"));
    }
    let placeholder = text.contains('<') && text.contains('>');
    // `unexpected` is not `expected`.
    let plain = text.replace("unexpected", "");
    if !(placeholder || ALLOWED.iter().any(|w| plain.contains(w))) {
        return Err("message: says nothing of what is allowed".into());
    }
    Ok(())
}

/// Words that say what is allowed, or the rule broken (`cannot be used with`,
/// `is not UTF-8 text`, a required field `missing`, the system's reason a
/// file cannot be opened).
const ALLOWED: [&str; 16] = [
    "needs",
    "expected",
    "allowed",
    "possible values",
    "one of",
    "must",
    "at most",
    "at least",
    "give",
    "cannot be used",
    "is not",
    "missing",
    "os error",
    "No such file",
    "Is a directory",
    "Permission denied",
];

/// `tube.element_length_m`, `lengths[1]`, `tip_mass_kg`: a key, not a word.
fn key_like(word: &str) -> bool {
    let word = word.trim_matches(|c: char| !c.is_alphanumeric() && c != '_' && c != '[' && c != ']');
    word.len() > 2
        && word.starts_with(|c: char| c.is_ascii_alphabetic())
        && word.chars().all(|c| c.is_ascii_alphanumeric() || "_.[]".contains(c))
        && word.contains(['_', '.', '['])
        && !word.ends_with('.')
}

fn says_status(stderr: &str) -> Result<(), String> {
    let line = stderr.trim_end().lines().last().unwrap_or("");
    let statuses = ["not converged", "time limit", "failed", "unreachable", "no plan", "impossible"];
    if !statuses.iter().any(|s| line.contains(s)) {
        return Err("exit 3: names no status".into());
    }
    if line.contains("time limit") {
        let work = ["iteration", "point", "step", "stride", "shape", " s "];
        return match work.iter().any(|w| line.contains(w)) {
            true => Ok(()),
            false => Err("exit 3: a time limit without what was done".into()),
        };
    }
    let solve = line.contains("solve") || line.contains("not converged");
    if solve && !(line.contains("residual") && line.contains("iteration")) {
        return Err("exit 3: a failed solve without its residual and iterations".into());
    }
    Ok(())
}

#[test]
fn hostile_command_lines_fail_cleanly_and_in_time() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus");
    let tmp = std::env::temp_dir().join(format!("leech-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let robot =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../leech/robots/leech.toml")).unwrap();
    let places = Places { data: data.clone(), tmp: tmp.clone(), robot };
    scratch_files(&tmp);
    let mut cases = parse(&std::fs::read_to_string(data.join("cases.txt")).unwrap(), &places);
    cases.extend(generated(&places));
    assert!(cases.len() >= 300, "a few hundred cases, {} given", cases.len());

    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let started = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..THREADS {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(case) = cases.get(i) else { break };
                if let Some(why) = run(case, &tmp, i) {
                    failures.lock().unwrap().push((i, why));
                }
            });
        }
    });
    std::fs::remove_dir_all(&tmp).ok();
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    let report: Vec<String> = failures
        .iter()
        .map(|(i, why)| {
            let case = &cases[*i];
            let marks = format!(
                "{}{}",
                if case.issue { " [issue 15]" } else { "" },
                if case.new_flag { " [new flag]" } else { "" }
            );
            format!("{}{marks}: {}\n    {why}", case.origin, case.command_line())
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed in {:.1} s:\n{}",
        failures.len(),
        cases.len(),
        started.elapsed().as_secs_f64(),
        report.join("\n")
    );
}

/// Issue 15: the lengths `reach` answers for this target are lengths `shape`
/// solves.
#[test]
fn lengths_from_reach_solve_in_shape() {
    let tmp = std::env::temp_dir().join(format!("leech-corpus-reach-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let args = |words: &[&str]| words.iter().map(OsString::from).collect::<Vec<_>>();
    // No --time-limit on reach yet: a generous fixed bound.
    let reach = run_bounded(&args(&["reach", "--target", "0.19326,0.30155", "--json"]), &tmp, 120.0, "reach");
    let answer: serde_json::Value = serde_json::from_slice(&reach.stdout).unwrap_or_else(|e| {
        std::fs::remove_dir_all(&tmp).ok();
        panic!("reach: {:?}, {e}: {}", reach.status, reach.stderr)
    });
    let lengths = format!("{},{}", answer["lengths_m"][0], answer["lengths_m"][1]);
    let shape =
        run_bounded(&args(&["shape", "--lengths", &lengths, "--time-limit", "10", "--json"]), &tmp, 11.0, "shape");
    std::fs::remove_dir_all(&tmp).ok();
    assert_eq!(shape.status.and_then(|s| s.code()), Some(0), "shape --lengths {lengths}: {}", shape.stderr);
    let solved: serde_json::Value = serde_json::from_slice(&shape.stdout).unwrap();
    assert_eq!(solved["status"], "converged", "shape --lengths {lengths}");
}
