//! The human form of an [`InfoReport`].

use std::fmt;

use super::InfoReport;

/// How many array items a decoded message shows before counting the rest.
const MAX_ITEMS_SHOWN: usize = 32;

impl fmt::Display for InfoReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let source = match self.source {
            super::CountSource::Summary => "counted by the summary",
            super::CountSource::Scan => "counted by scanning the file",
        };
        writeln!(
            f,
            "file:        {} ({} bytes)",
            self.path.display(),
            self.size_bytes
        )?;
        writeln!(f, "library:     {}", self.library)?;
        writeln!(f, "profile:     {}", self.profile)?;
        match &self.written_by {
            Some(super::WrittenBy::Versioned {
                format_version,
                lewis_version,
                interfaces,
            }) => writeln!(
                f,
                "lewis:       {lewis_version} (recording format {format_version}, interfaces {interfaces})"
            )?,
            Some(super::WrittenBy::BeforeVersioning) => {
                writeln!(f, "lewis:       written before versioning")?;
            }
            None => {}
        }
        writeln!(f, "messages:    {} ({source})", self.message_count)?;
        if let (Some(start), Some(end), Some(duration)) =
            (self.start_ns, self.end_ns, self.duration_ns)
        {
            writeln!(f, "start:       {} ({})", utc_time(start), seconds(start))?;
            writeln!(f, "end:         {} ({})", utc_time(end), seconds(end))?;
            writeln!(f, "duration:    {} s", seconds(duration))?;
        }
        let compressions: Vec<String> = self
            .compressions
            .iter()
            .map(|c| format!("{}: {}", c.compression, c.chunk_count))
            .collect();
        if compressions.is_empty() {
            writeln!(f, "chunks:      {}", self.chunk_count)?;
        } else {
            writeln!(
                f,
                "chunks:      {} ({})",
                self.chunk_count,
                compressions.join(", ")
            )?;
        }
        writeln!(f, "attachments: {}", self.attachment_count)?;
        if self.metadata_names.is_empty() {
            writeln!(f, "metadata:    0")?;
        } else {
            let names = self.metadata_names.join(", ");
            writeln!(f, "metadata:    {} ({names})", self.metadata_names.len())?;
        }
        self.channel_table(f)?;
        for warning in &self.warnings {
            writeln!(f, "warning: {}", warning.message)?;
        }
        if let Some(damage) = &self.damage {
            let what = if damage.truncated {
                "truncated"
            } else {
                "damaged"
            };
            writeln!(
                f,
                "{what}: {}; what is listed is what could be read",
                damage.detail
            )?;
            writeln!(f, "  hint: {}", damage.hint)?;
        }
        if !self.messages.is_empty() {
            writeln!(f, "first messages:")?;
        }
        for message in &self.messages {
            write!(f, "  {} {} ", seconds(message.log_time_ns), message.topic)?;
            match (&message.value, &message.error) {
                (Some(value), _) => writeln!(f, "{}", value.display_limited(MAX_ITEMS_SHOWN))?,
                (None, Some(error)) => {
                    writeln!(f, "({} bytes, not decoded: {error})", message.size_bytes)?;
                }
                (None, None) => writeln!(f, "({} bytes)", message.size_bytes)?,
            }
        }
        Ok(())
    }
}

impl InfoReport {
    fn channel_table(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let with_losses = !self.lost_messages.is_empty();
        let mut rows = vec![
            [
                "id", "topic", "schema", "encoding", "messages", "rate_hz", "lost",
            ]
            .map(str::to_owned),
        ];
        for channel in &self.channels {
            let schema = match (&channel.schema_name, &channel.schema_encoding) {
                (Some(name), Some(encoding)) => format!("{name} ({encoding})"),
                _ => "-".to_owned(),
            };
            rows.push([
                channel.id.to_string(),
                channel.topic.clone(),
                schema,
                channel.message_encoding.clone(),
                channel.message_count.to_string(),
                channel
                    .rate_hz
                    .map_or("-".to_owned(), |rate| format!("{rate:.2}")),
                channel
                    .lost_count
                    .map_or("-".to_owned(), |lost| lost.to_string()),
            ]);
        }
        let columns = if with_losses { 7 } else { 6 };
        let mut widths = [0; 7];
        for row in &rows {
            for (width, cell) in widths.iter_mut().zip(row) {
                *width = (*width).max(cell.chars().count());
            }
        }
        writeln!(f, "channels:    {}", self.channels.len())?;
        if self.channels.is_empty() {
            rows.clear();
        }
        for row in &rows {
            let mut line = String::from(" ");
            for (index, cell) in row.iter().enumerate().take(columns) {
                let width = widths[index];
                // Numbers right-aligned, text left-aligned.
                if matches!(index, 0 | 4 | 5 | 6) {
                    line.push_str(&format!(" {cell:>width$}"));
                } else {
                    line.push_str(&format!(" {cell:<width$}"));
                }
            }
            writeln!(f, "{}", line.trim_end())?;
        }
        let orphans: Vec<String> = self
            .lost_messages
            .iter()
            .filter(|(topic, _)| !self.channels.iter().any(|c| &c.topic == *topic))
            .map(|(topic, count)| format!("{topic}: {count}"))
            .collect();
        if !orphans.is_empty() {
            writeln!(
                f,
                "lost on topics without a channel: {}",
                orphans.join(", ")
            )?;
        }
        Ok(())
    }
}

/// Nanoseconds as `seconds.nanoseconds`.
pub(crate) fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// Nanoseconds since the Unix epoch as an ISO 8601 UTC time with nanoseconds.
pub(crate) fn utc_time(ns: u64) -> String {
    let secs = ns / 1_000_000_000;
    let (days, day_secs) = (secs / 86_400, secs % 86_400);
    let (year, month, day) = civil_from_days(days);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:09}Z",
        day_secs / 3600,
        day_secs / 60 % 60,
        day_secs % 60,
        ns % 1_000_000_000
    )
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (Howard Hinnant's
/// `civil_from_days`, for non-negative days).
fn civil_from_days(days: u64) -> (u64, u64, u64) {
    let z = days + 719_468;
    let era = z / 146_097;
    let day_of_era = z % 146_097;
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let shifted_month = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * shifted_month + 2) / 5 + 1;
    let month = if shifted_month < 10 {
        shifted_month + 3
    } else {
        shifted_month - 9
    };
    let year = year_of_era + era * 400 + u64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_times_match_known_dates() {
        assert_eq!(utc_time(0), "1970-01-01T00:00:00.000000000Z");
        assert_eq!(
            utc_time(1_585_866_235_112_411_371),
            "2020-04-02T22:23:55.112411371Z"
        );
        assert_eq!(
            utc_time(951_782_400_000_000_000),
            "2000-02-29T00:00:00.000000000Z"
        );
        assert_eq!(
            utc_time(4_107_542_399_999_999_999),
            "2100-02-28T23:59:59.999999999Z"
        );
    }

    #[test]
    fn seconds_keep_every_nanosecond() {
        assert_eq!(seconds(1_507_888_659), "1.507888659");
        assert_eq!(seconds(5), "0.000000005");
    }
}
