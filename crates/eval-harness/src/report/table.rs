//! A table as data, written out as Markdown (`report.md`) or as HTML (`index.html`): the
//! same cells either way.

use super::html::escape;

/// A cell: its text, bold where the paper bolds (the best result of a column).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Cell {
    pub text: String,
    pub bold: bool,
}

impl From<String> for Cell {
    fn from(text: String) -> Cell {
        Cell { text, bold: false }
    }
}

impl From<&str> for Cell {
    fn from(text: &str) -> Cell {
        Cell { text: text.to_string(), bold: false }
    }
}

/// One table of the report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Table {
    /// The anchor in index.html.
    pub id: &'static str,
    pub title: String,
    /// What the numbers are, as the paper's caption says it.
    pub caption: String,
    pub columns: Vec<String>,
    /// The group of each column (a benchmark; empty for none): one header cell spanning the
    /// group's columns in HTML, a prefix of each column's name in Markdown.
    pub groups: Vec<String>,
    /// Right-aligned (numeric) columns.
    pub numeric: Vec<bool>,
    pub rows: Vec<Vec<Cell>>,
    /// Said instead of the table when it has no rows.
    pub empty: String,
    /// Lines under the table (footnotes).
    pub notes: Vec<String>,
}

impl Table {
    pub fn new(id: &'static str, title: impl Into<String>, caption: impl Into<String>, empty: impl Into<String>) -> Table {
        Table {
            id,
            title: title.into(),
            caption: caption.into(),
            columns: Vec::new(),
            groups: Vec::new(),
            numeric: Vec::new(),
            rows: Vec::new(),
            empty: empty.into(),
            notes: Vec::new(),
        }
    }

    pub fn column(&mut self, name: impl Into<String>, numeric: bool) {
        self.grouped_column("", name, numeric);
    }

    /// A column under `group` (a benchmark's columns under its name).
    pub fn grouped_column(&mut self, group: impl Into<String>, name: impl Into<String>, numeric: bool) {
        self.groups.push(group.into());
        self.columns.push(name.into());
        self.numeric.push(numeric);
    }

    /// Bold the largest value of each given column (ties all bold); cells that are not
    /// numbers (dashes) take no part.
    pub fn bold_best(&mut self, columns: impl IntoIterator<Item = usize>) {
        for column in columns {
            let value = |cell: &Cell| cell.text.split_whitespace().next().and_then(|t| t.parse::<f64>().ok());
            let best = self.rows.iter().filter_map(|row| value(&row[column])).fold(f64::NEG_INFINITY, f64::max);
            for row in &mut self.rows {
                if value(&row[column]) == Some(best) {
                    row[column].bold = true;
                }
            }
        }
    }

    pub fn markdown(&self) -> String {
        let mut out = format!("## {}\n\n{}\n\n", self.title, self.caption);
        if self.rows.is_empty() {
            out.push_str(&format!("_{}_\n", self.empty));
        } else {
            let cell = |text: &str| markdown_cell(text);
            let names = self.columns.iter().zip(&self.groups).map(|(c, g)| if g.is_empty() { cell(c) } else { cell(&format!("{g} {c}")) });
            out.push_str(&format!("| {} |\n", names.collect::<Vec<_>>().join(" | ")));
            out.push_str(&format!("|{}|\n", self.numeric.iter().map(|n| if *n { "---:" } else { "---" }).collect::<Vec<_>>().join("|")));
            for row in &self.rows {
                let cells: Vec<String> =
                    row.iter().map(|c| if c.bold { format!("**{}**", cell(&c.text)) } else { cell(&c.text) }).collect();
                out.push_str(&format!("| {} |\n", cells.join(" | ")));
            }
        }
        for note in &self.notes {
            out.push_str(&format!("\n{note}\n"));
        }
        out
    }

    pub fn html(&self) -> String {
        let mut out =
            format!("<section id=\"{}\">\n<h2>{}</h2>\n<p class=\"caption\">{}</p>\n", self.id, escape(&self.title), escape(&self.caption));
        if self.rows.is_empty() {
            out.push_str(&format!("<p class=\"empty\">{}</p>\n", escape(&self.empty)));
        } else {
            let class = |numeric: bool| if numeric { " class=\"num\"" } else { "" };
            out.push_str("<div class=\"wide\"><table>\n<thead>");
            if self.groups.iter().any(|g| !g.is_empty()) {
                out.push_str("<tr>");
                let mut start = 0;
                while start < self.groups.len() {
                    let end = (start..self.groups.len()).find(|&i| self.groups[i] != self.groups[start]).unwrap_or(self.groups.len());
                    let class = if self.groups[start].is_empty() { "" } else { " class=\"group\"" };
                    out.push_str(&format!("<th colspan=\"{}\"{class}>{}</th>", end - start, escape(&self.groups[start])));
                    start = end;
                }
                out.push_str("</tr>\n");
            }
            out.push_str("<tr>");
            for (name, numeric) in self.columns.iter().zip(&self.numeric) {
                out.push_str(&format!("<th{}>{}</th>", class(*numeric), escape(name)));
            }
            out.push_str("</tr></thead>\n<tbody>\n");
            for row in &self.rows {
                out.push_str("<tr>");
                for (cell, numeric) in row.iter().zip(&self.numeric) {
                    let text = if cell.bold { format!("<strong>{}</strong>", escape(&cell.text)) } else { escape(&cell.text) };
                    out.push_str(&format!("<td{}>{text}</td>", class(*numeric)));
                }
                out.push_str("</tr>\n");
            }
            out.push_str("</tbody>\n</table></div>\n");
        }
        for note in &self.notes {
            out.push_str(&format!("<p class=\"note\">{}</p>\n", escape(note)));
        }
        out.push_str("</section>\n");
        out
    }
}

/// A table cell's text as Markdown shows it as written: `|` escaped (it would end the cell),
/// a line break a space, and `<` before what would start an HTML tag (`<i>` in a model's file
/// name) as `&lt;`, so that a renderer shows it rather than takes it for markup. A `<` before a
/// digit (`<0.001`) starts no tag, and stays.
fn markdown_cell(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '|' => out.push_str("\\|"),
            '\n' => out.push(' '),
            '<' if chars.peek().is_some_and(|n| n.is_ascii_alphabetic() || matches!(n, '/' | '!' | '?')) => out.push_str("&lt;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::markdown_cell;

    #[test]
    fn a_cell_shows_what_would_be_markup_as_written() {
        assert_eq!(markdown_cell("we<i>rd&\"x.gguf | 2"), "we&lt;i>rd&\"x.gguf \\| 2");
        assert_eq!(markdown_cell("</b><!-- x --><?x"), "&lt;/b>&lt;!-- x -->&lt;?x");
        assert_eq!(markdown_cell("<0.001"), "<0.001");
        assert_eq!(markdown_cell("a\nb <"), "a b <");
    }
}
