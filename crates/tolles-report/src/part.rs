//! Reports placed one after another on a page: a report of several scalars holds each
//! scalar's page as a part, its sections headed with the scalar's name.

use crate::{Block, Report};

impl Report {
    /// Appends `part`: a section `{name}: Summary` with its summary cards as a list and their
    /// notes, then its blocks with each section heading prefixed `{name}: ` (so the table of
    /// contents and the section ids stay unique). Its title and subtitle are dropped.
    pub fn part(mut self, name: &str, part: Report) -> Report {
        self.blocks.push(Block::Section(format!("{name}: Summary")));
        if !part.summary.is_empty() {
            self.blocks.push(Block::KeyValues(part.summary));
        }
        self.blocks
            .extend(part.summary_notes.into_iter().map(Block::Paragraph));
        self.blocks
            .extend(part.blocks.into_iter().map(|block| match block {
                Block::Section(heading) => Block::Section(format!("{name}: {heading}")),
                other => other,
            }));
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_prefixes_its_sections_and_lists_its_summary() {
        let part = Report::new("dropped")
            .summary(&[("FOM", "1 nT")])
            .summary_note("what FOM is")
            .paragraph("before any section")
            .section("Signals");
        let page = Report::new("page").part("mag_1", part);
        assert_eq!(
            page.blocks,
            [
                Block::Section("mag_1: Summary".into()),
                Block::KeyValues(vec![("FOM".into(), "1 nT".into())]),
                Block::Paragraph("what FOM is".into()),
                Block::Paragraph("before any section".into()),
                Block::Section("mag_1: Signals".into()),
            ]
        );
        assert!(page.summary.is_empty());
    }
}
