//! Names as messages show them and as report files are called: kept in one leaf module so
//! that the case checks (which refuse two names that would make one file) and the report
//! (which writes the files) agree without importing each other.

/// A name as it may appear in a message: at most 80 characters.
pub fn clip(s: &str) -> String {
    const MAX: usize = 80;
    if s.chars().count() <= MAX {
        s.to_string()
    } else {
        let head: String = s.chars().take(MAX).collect();
        format!("{head}… ({} bytes)", s.len())
    }
}

/// Where a map's SVG goes, relative to the report.
pub fn map_file(method: &str, material: &str, x: &str, y: &str) -> String {
    let clean = |s: &str| {
        s.chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' })
            .collect::<String>()
    };
    format!(
        "maps/{}__{}__{}_{}.svg",
        clean(method),
        clean(material),
        clean(x),
        clean(y)
    )
}

/// Where a material's speed-against-accuracy chart goes, relative to the report.
pub fn chart_file(material: &str) -> String {
    let clean: String = material
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' })
        .collect();
    format!("speed_accuracy__{clean}.svg")
}
