//! Checks of a case file's values, beyond their types: every error names the file, the
//! key and the value. Kept apart from the parser (`case.rs`) so the rules live in
//! one place: names that become file names, distributions that can only make valid
//! configurations, positive floors and tolerances, duplicate methods, search sizes.

use crate::input::case::{Case, Dist, Geometry, MaterialFamily};
pub use crate::input::names::clip;
use crate::input::names::{chart_file, map_file};
use crate::limits::MAX_NAME;
use std::collections::BTreeMap;

// The caps on counts live with every other cap, in `crate::limits`.
pub use crate::limits::{MAX_SEARCH_BATCH, MAX_STEPS, MAX_TOPUP_DRAWS};

fn shown(d: &Dist) -> String {
    match *d {
        Dist::Fixed { value } => format!("fixed {value}"),
        Dist::Uniform { min, max } => format!("uniform [{min}, {max}]"),
        Dist::LogUniform { min, max } => format!("log_uniform [{min}, {max}]"),
        Dist::SignedLogUniform { min, max } => format!("signed_log_uniform ±[{min}, {max}]"),
    }
}

/// The smallest and largest value a distribution can draw (signed: of either sign).
fn range(d: &Dist) -> (f64, f64) {
    match *d {
        Dist::Fixed { value } => (value, value),
        Dist::Uniform { min, max } | Dist::LogUniform { min, max } => (min, max),
        Dist::SignedLogUniform { max, .. } => (-max, max),
    }
}

fn valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphanumeric())
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
        && name.len() <= MAX_NAME
}

/// A `[budget]`'s values: a known statistic, a quantile strictly between 0 and 1, a finite value
/// > 0, at least one configuration per region.
fn budget(b: &crate::input::case::Budget) -> Result<(), String> {
    use crate::input::case::BUDGET_STATISTIC;
    if b.statistic != BUDGET_STATISTIC {
        return Err(format!(
            "`budget.statistic` = \"{}\": the only statistic a budget can name is \"{BUDGET_STATISTIC}\" \
             (the relative error of the f32 result, docs/statistics.md)",
            clip(&b.statistic)
        ));
    }
    let q = b.quantile;
    if !(q > 0.0 && q < 1.0) {
        let hint = if q > 1.0 && q < 100.0 {
            format!(" (for p{q} write {})", q / 100.0)
        } else {
            String::new()
        };
        return Err(format!(
            "`budget.quantile` = {q}: a quantile is a fraction strictly between 0 and 1, 0.99 for p99{hint}"
        ));
    }
    if !(b.value > 0.0 && b.value.is_finite()) {
        return Err(format!(
            "`budget.value` = {}: the most the statistic may be must be a finite number > 0",
            b.value
        ));
    }
    if b.min_count == 0 {
        return Err("`budget.min_count` = 0: a region needs at least 1 configuration to be judged".into());
    }
    Ok(())
}

/// Every check below; `Err` is the message without the file name (the caller adds it).
pub fn check(case: &Case) -> Result<(), String> {
    if !valid_name(&case.name) {
        return Err(format!(
            "`name` = \"{}\": a case name becomes the report folder's name, so it must be 1–{MAX_NAME} \
             letters, digits, '.', '_' or '-', starting with a letter or digit",
            clip(&case.name)
        ));
    }
    let mut seen = BTreeMap::new();
    for (i, m) in case.methods.iter().enumerate() {
        if let Some(j) = seen.insert(m.as_str(), i) {
            return Err(format!(
                "`methods`: \"{}\" is listed twice (entries {} and {})",
                clip(m),
                j + 1,
                i + 1
            ));
        }
    }
    if let Some(g) = &case.geometry {
        geometry(g, "geometry")?;
    }
    let mut names = BTreeMap::new();
    let mut charts = BTreeMap::new();
    for (i, m) in case.materials.iter().enumerate() {
        if m.name.is_empty() {
            return Err(format!("`materials[{i}].name` = \"\": a material needs a name"));
        }
        if let Some(j) = names.insert(m.name.as_str(), i) {
            return Err(format!(
                "`materials[{i}].name` = \"{}\": material names must be unique (also materials[{j}])",
                clip(&m.name)
            ));
        }
        if let Some(other) = charts.insert(chart_file(&m.name), &m.name) {
            return Err(format!(
                "`materials[{i}].name` = \"{}\" and \"{}\" map to the same chart file `{}`: rename one",
                clip(&m.name),
                clip(other),
                chart_file(&m.name)
            ));
        }
        // The same cap as `--count`: a case file is no way around it.
        crate::limits::check_count(&format!("`materials[{i}].count` ="), m.count as u64)?;
        material(m, i)?;
        if let Some(t) = &m.texture {
            let at = format!("materials[{i}].texture");
            t.check(&at)?;
            if case.geometry_of(m).rect_width.is_some() {
                return Err(format!(
                    "`{at}`: a textured light is a line or a tube, and the geometry of materials[{i}] (\"{}\") has a \
                     `rect_width` (a rectangle is never textured)",
                    clip(&m.name)
                ));
            }
        }
    }
    if case.min_per_bin as u64 > crate::limits::MAX_COUNT {
        return Err(format!(
            "`min_per_bin` = {}: more than the {} configurations per family a sweep takes",
            case.min_per_bin,
            crate::limits::MAX_COUNT
        ));
    }
    for (i, b) in case.bins.iter().enumerate() {
        if let Some(n) = b.min_per_bin.filter(|&n| n as u64 > crate::limits::MAX_COUNT) {
            return Err(format!(
                "`bins[{i}].min_per_bin` = {n}: more than the {} configurations per family a sweep takes",
                crate::limits::MAX_COUNT
            ));
        }
    }
    let mut maps = BTreeMap::new();
    for (k, map) in case.maps.iter().enumerate() {
        for label in case.methods.iter().filter(|l| map.shows(l)) {
            for mat in &case.materials {
                let file = map_file(label, &mat.name, &map.x.axis, &map.y.axis);
                let key = (label.clone(), mat.name.clone(), k);
                if let Some((l, n, _)) = maps.insert(file.clone(), key) {
                    if l != *label || n != mat.name {
                        return Err(format!(
                            "`maps[{k}]`: `{}` on \"{}\" and `{}` on \"{}\" map to the same file `{file}`: \
                             rename a method or material",
                            clip(label),
                            clip(&mat.name),
                            clip(&l),
                            clip(&n)
                        ));
                    }
                    return Err(format!(
                        "`maps[{k}]`: the map {} × {} appears twice",
                        map.x.axis, map.y.axis
                    ));
                }
            }
        }
    }
    for b in case.bins.iter().chain(case.maps.iter().flat_map(|m| [&m.x, &m.y])) {
        if let Some(e) = b.edges.iter().find(|e| !e.is_finite()) {
            return Err(format!("`bins` `{}`: edge {e} is not finite", b.axis));
        }
    }
    drawn_axes(case)?;
    for (target, &floor) in &case.error_floor {
        if !(floor > 0.0 && floor.is_finite()) {
            return Err(format!(
                "`error_floor.{target}` = {floor}: the floor of a relative error's denominator must be a \
                 finite number > 0"
            ));
        }
    }
    if let Some(b) = &case.budget {
        budget(b)?;
    }
    for (method, t) in &case.tolerances {
        for (key, v) in [("median", t.median), ("p99", t.p99), ("max", t.max)] {
            if let Some(v) = v.filter(|v| !(*v >= 0.0 && v.is_finite())) {
                return Err(format!(
                    "`tolerances.\"{}\".{key}` = {v}: a tolerance must be a finite number >= 0",
                    clip(method)
                ));
            }
        }
    }
    for (i, [a, b]) in case.compare.iter().enumerate() {
        if a == b {
            return Err(format!(
                "`compare[{i}]` = [\"{}\", \"{}\"]: a method compared with itself",
                clip(a),
                clip(b)
            ));
        }
    }
    if let Some(s) = &case.search {
        if s.restarts == 0 || s.population == 0 {
            return Err(format!(
                "`search.restarts` = {}, `search.population` = {}: both must be at least 1",
                s.restarts, s.population
            ));
        }
        let batch = s.restarts.checked_mul(s.population).filter(|&b| b <= MAX_SEARCH_BATCH);
        if batch.is_none() {
            return Err(format!(
                "`search.restarts` × `search.population` = {} × {}: more than {MAX_SEARCH_BATCH} candidates per step",
                s.restarts, s.population
            ));
        }
        if s.steps > MAX_STEPS {
            return Err(format!("`search.steps` = {}: at most {MAX_STEPS}", s.steps));
        }
    }
    if let Some(s) = &case.disagreements {
        if s.restarts == 0 || s.population == 0 {
            return Err(format!(
                "`disagreements.restarts` = {}, `disagreements.population` = {}: both must be at least 1",
                s.restarts, s.population
            ));
        }
        if s.restarts
            .checked_mul(s.population)
            .is_none_or(|b| b > MAX_SEARCH_BATCH)
        {
            return Err(format!(
                "`disagreements.restarts` × `disagreements.population` = {} × {}: more than {MAX_SEARCH_BATCH} \
                 candidates per step",
                s.restarts, s.population
            ));
        }
        if s.steps > MAX_STEPS {
            return Err(format!("`disagreements.steps` = {}: at most {MAX_STEPS}", s.steps));
        }
        if !(s.epsilon > 0.0 && s.epsilon.is_finite()) {
            return Err(format!(
                "`disagreements.epsilon` = {}: the smallest error a ratio divides by must be a finite number > 0",
                s.epsilon
            ));
        }
    }
    if case.topup_draws > MAX_TOPUP_DRAWS {
        return Err(format!(
            "`topup_draws` = {}: at most {MAX_TOPUP_DRAWS} (top-up draws per family, as a multiple of its count)",
            case.topup_draws
        ));
    }
    Ok(())
}

/// The values a family's configurations take on a bin axis (`sampler::Axes`): None when
/// the family never draws it (its value is NaN there), the drawn distribution's range for an
/// axis that is a drawn parameter itself, and all numbers for a derived one.
pub fn axis_range(case: &Case, family: &MaterialFamily, axis: &str) -> Option<(f64, f64)> {
    use crate::input::case::MaterialKind::{Diffuse, Ggx, LtcGgx};
    let g = case.geometry_of(family);
    let all = (f64::NEG_INFINITY, f64::INFINITY);
    let or = |d: Option<&Dist>, default: f64| d.map_or((default, default), range);
    let ggx = matches!(family.kind, Ggx | LtcGgx);
    match axis {
        "alpha" => (family.kind != Diffuse).then(|| or(family.alpha.as_ref(), 1.0)),
        "view_angle" => ggx.then(|| or(family.view_angle.as_ref(), 45.0)),
        "anisotropy" => ggx.then(|| or(family.anisotropy.as_ref(), 1.0)),
        // Defined where the view is known: the `ggx` material (src/input/sampler.rs).
        "highlight" => (family.kind == Ggx).then_some((0.0, 180.0)),
        // Drawn by the family's texture pattern (src/input/case/texture.rs).
        "frequency" => family
            .texture
            .as_ref()
            .and_then(|t| t.pattern.frequency.as_ref())
            .map(range),
        "texture_contrast" => family
            .texture
            .as_ref()
            .and_then(|t| t.pattern.contrast.as_ref())
            .map(range),
        "distance_over_length" => Some(if g.endpoint_height.is_some() {
            all
        } else {
            let (lo, hi) = range(&g.length);
            (1.0 / hi, 1.0 / lo)
        }),
        "radius" => g.radius.as_ref().map(range),
        "cap_straddle" => g.radius.as_ref().map(|_| (0.0, 1.0)),
        "width" => g.rect_width.as_ref().map(range),
        "rect_angle" => g.rect_width.as_ref().map(|_| or(g.rect_angle.as_ref(), 0.0)),
        "elevation" => Some(range(&g.elevation)),
        "center" => Some(range(&g.center)),
        // A moved end point changes the length.
        "length" => Some(if g.endpoint_height.is_some() {
            all
        } else {
            range(&g.length)
        }),
        _ => Some(all),
    }
}

/// Refuses a bin or map axis on which no configuration of the case can fall: one no family
/// draws, or whose edges miss every value drawn. Its bins or map would be empty, with exit 0.
fn drawn_axes(case: &Case) -> Result<(), String> {
    let keys = case.bins.iter().enumerate().map(|(i, b)| (format!("bins[{i}]"), b));
    let maps = case.maps.iter().enumerate().flat_map(|(i, m)| {
        let map = format!("maps[{i}]` ({} × {})", m.x.axis, m.y.axis);
        [(format!("{map}: `x"), &m.x), (format!("{map}: `y"), &m.y)]
    });
    for (key, b) in keys.chain(maps) {
        let (lo, hi) = (b.edges[0], b.edges[b.edges.len() - 1]);
        let ranges: Vec<(f64, f64)> = case
            .materials
            .iter()
            .filter_map(|f| axis_range(case, f, &b.axis))
            .collect();
        if ranges.is_empty() {
            let needs = match b.axis.as_str() {
                "alpha" => "an LTC or ggx material",
                "view_angle" | "anisotropy" => "a ggx or ltc_ggx material",
                "highlight" => "a ggx material",
                "frequency" => "a `[materials.texture]` whose pattern draws a `frequency` (stripes)",
                "texture_contrast" => "a `[materials.texture]` whose pattern draws a `contrast`",
                "radius" | "cap_straddle" => "a geometry with a `radius`",
                "width" | "rect_angle" => "a geometry with a `rect_width`",
                _ => "another case",
            };
            return Err(format!(
                "`{key}.axis` = \"{}\": no family of the case draws it (it needs {needs}), so every one of its \
                 cells would be empty",
                b.axis
            ));
        }
        if !ranges.iter().any(|&(a, z)| a <= hi && z >= lo) {
            let drawn: Vec<String> = ranges.iter().map(|(a, z)| format!("[{a}, {z}]")).collect();
            return Err(format!(
                "`{key}.edges` = [{lo} … {hi}]: axis `{}` is drawn only in {}, so every one of its cells would be \
                 empty",
                b.axis,
                drawn.join(", ")
            ));
        }
    }
    Ok(())
}

/// A parameter that only makes sense when positive (a length, a roughness).
fn positive(key: &str, d: &Dist) -> Result<(), String> {
    let (lo, _) = range(d);
    if matches!(d, Dist::SignedLogUniform { .. }) || !(lo > 0.0) {
        return Err(format!(
            "`{key}` = {}: must draw only values > 0, so it cannot make degenerate configurations",
            shown(d)
        ));
    }
    Ok(())
}

fn geometry(g: &Geometry, at: &str) -> Result<(), String> {
    positive(&format!("{at}.distance"), &g.distance)?;
    positive(&format!("{at}.length"), &g.length)?;
    if let Some(r) = &g.radius {
        positive(&format!("{at}.radius"), r)?;
        let (_, hi) = range(r);
        if !(hi < 1.0) {
            return Err(format!(
                "`{at}.radius` = {}: the radius is in units of the line's distance d, and a radius >= 1 puts \
                 the shading point inside the tube (draws would be redrawn, changing the distribution)",
                shown(r)
            ));
        }
    }
    if let Some(w) = &g.rect_width {
        positive(&format!("{at}.rect_width"), w)?;
    }
    Ok(())
}

fn material(m: &MaterialFamily, i: usize) -> Result<(), String> {
    let at = format!("materials[{i}]");
    if let Some(g) = &m.geometry {
        geometry(g, &format!("{at}.geometry"))?;
    }
    for (key, d) in [("alpha", &m.alpha), ("aspect", &m.aspect)] {
        if let Some(d) = d {
            positive(&format!("{at}.{key}"), d)?;
        }
    }
    if let Some(p) = &m.peak {
        let (lo, hi) = range(p);
        if !(lo > -90.0 && hi < 90.0) {
            return Err(format!(
                "`{at}.peak` = {}: the lobe's peak must stay within (-90, 90) degrees of the normal",
                shown(p)
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = r#"
name = "t"
title = "t"
seed = 1
methods = ["line.ltc2023", "line.ltc2017"]
[geometry]
elevation = { dist = "uniform", min = 0.0, max = 90.0 }
tilt_angle = { dist = "uniform", min = 0.0, max = 180.0 }
length = { dist = "log_uniform", min = 0.1, max = 10.0 }
center = { dist = "fixed", value = 0.0 }
[[materials]]
name = "diffuse"
kind = "diffuse"
count = 10
"#;

    fn err(text: &str) -> String {
        Case::parse("c.toml", text).unwrap_err().to_string()
    }

    #[test]
    fn each_error_names_file_key_and_value() {
        assert!(Case::parse("c.toml", BASE).is_ok());
        let e = err(&BASE.replace("name = \"t\"", "name = \"../../x\""));
        assert!(e.starts_with("c.toml:") && e.contains("`name` = \"../../x\""), "{e}");
        let e = err(&BASE.replace("seed = 1", "seed = 1\nerror_floor = { line = 0.0 }"));
        assert!(e.contains("`error_floor.line` = 0"), "{e}");
        let e = err(&BASE.replace("seed = 1", "seed = 1\nerror_floor = { line = -1.0 }"));
        assert!(e.contains("`error_floor.line` = -1"), "{e}");
        let e = err(&BASE.replace("seed = 1", "seed = 1\nerror_floor = { line = nan }"));
        assert!(e.contains("`error_floor.line` = NaN"), "{e}");
        let e = err(&BASE.replace("\"line.ltc2017\"]", "\"line.ltc2023\"]"));
        assert!(e.contains("`methods`: \"line.ltc2023\" is listed twice"), "{e}");
        let e = err(&BASE.replace(
            "min = 0.1, max = 10.0",
            "min = 0.1, max = 10.0 }\nradius = { dist = \"uniform\", min = 0.5, max = 1.5",
        ));
        assert!(e.contains("`geometry.radius` = uniform [0.5, 1.5]"), "{e}");
        let e = err(&BASE.replace(
            "center = { dist = \"fixed\", value = 0.0 }",
            "center = { dist = \"fixed\", value = 0.0 }\ndistance = { dist = \"fixed\", value = -1.0 }",
        ));
        assert!(e.contains("`geometry.distance` = fixed -1"), "{e}");
        let two = format!("{BASE}[[materials]]\nname = \"diffuse\"\nkind = \"diffuse\"\ncount = 1\n");
        let e = err(&two);
        assert!(
            e.contains("`materials[1].name` = \"diffuse\": material names must be unique"),
            "{e}"
        );
        let near = format!("{BASE}[[materials]]\nname = \"diff use\"\nkind = \"diffuse\"\ncount = 1\n[[materials]]\nname = \"diff,use\"\nkind = \"diffuse\"\ncount = 1\n");
        assert!(err(&near).contains("same chart file"), "{}", err(&near));
        let e = err(&format!("{BASE}[tolerances.\"line.ltc2023\"]\np99 = -0.1\n"));
        assert!(e.contains("`tolerances.\"line.ltc2023\".p99` = -0.1"), "{e}");
        let e = err(&format!("{BASE}[search]\nmethods = [\"line.ltc2023\"]\nrestarts = 0\n"));
        assert!(e.contains("`search.restarts` = 0"), "{e}");
    }
}
