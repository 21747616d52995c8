//! Which faces are leaves: name patterns (substring or glob) against a face's object, group
//! and material names, and the group labels of the result.
use crate::scene::obj::scan::NameSet;
use std::collections::HashMap;

/// Whether `name` matches `pattern`, case-insensitively: a glob (`*` any run, `?` any one
/// character) over the whole name when the pattern has `*` or `?`, else a substring.
pub fn pattern_matches(pattern: &str, name: &str) -> bool {
    let (p, n) = (pattern.to_lowercase(), name.to_lowercase());
    if p.contains(['*', '?']) {
        let p: Vec<char> = p.chars().collect();
        let n: Vec<char> = n.chars().collect();
        glob(&p, &n)
    } else {
        n.contains(&p)
    }
}

/// Iterative wildcard match with single-star backtracking (linear-ish, never exponential).
fn glob(p: &[char], s: &[char]) -> bool {
    let (mut pi, mut si) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == s[si]) {
            pi += 1;
            si += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, si));
            pi += 1;
        } else if let Some((sp, ss)) = star {
            pi = sp + 1;
            si = ss + 1;
            star = Some((sp, ss + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// A face's leaf/bark class and its group label.
pub(super) fn classify(set: &NameSet, patterns: &[String]) -> (bool, String) {
    let names = [&set.material, &set.group, &set.object];
    for name in names.into_iter().flatten() {
        if patterns.iter().any(|p| pattern_matches(p, name)) {
            return (true, name.clone());
        }
    }
    let label = names.into_iter().flatten().next().cloned();
    (false, label.unwrap_or_else(|| "default".to_string()))
}

#[derive(Default)]
pub(super) struct Labels {
    pub(super) names: Vec<String>,
    pub(super) index: HashMap<String, u32>,
}

impl Labels {
    pub(super) fn get(&mut self, name: &str) -> u32 {
        if let Some(&i) = self.index.get(name) {
            return i;
        }
        let i = self.names.len() as u32;
        self.names.push(name.to_string());
        self.index.insert(name.to_string(), i);
        i
    }
}
