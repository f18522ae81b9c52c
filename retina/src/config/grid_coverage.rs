//! The eye's grid against the tables it reads: a grid inside the settings' range ([300, 900]
//! nm) may still reach past the cone absorbances and ocular densities, which cover less; the
//! error names the grid's end that does and the range the tables allow.

use super::RetinaConfig;
use crate::error::{Result, RetinaError};

impl RetinaConfig {
    /// Checks that the tables the eye reads (cone absorbances, lens and macular densities)
    /// cover `grid`: its range is the settings' range ([300, 900] nm), the tables' is narrower,
    /// so the error names the grid's end that lies beyond them and the range they allow.
    pub(super) fn validate_grid_coverage(&self) -> Result<()> {
        let Ok(grid) = self.grid.grid() else {
            return Ok(()); // a malformed grid is named where the grid is built
        };
        let spec = crate::mosaic::MosaicSpec::parse(&self.cones)?;
        let classes = spec
            .class_names()
            .iter()
            .map(|name| spec.class(name))
            .collect::<Result<Vec<_>>>()?;
        match colorimetry::sensitivities(&classes, &self.template, &grid) {
            Err(colorimetry::ColorimetryError::NotCovered {
                table,
                table_min_nm,
                table_max_nm,
                requested_min_nm,
                ..
            }) => {
                let (name, value) = if requested_min_nm < table_min_nm {
                    ("grid.start_nm", self.grid.start_nm)
                } else {
                    ("grid.end_nm", self.grid.end_nm)
                };
                Err(RetinaError::setting(
                    name,
                    format!(
                        "{value} nm lies beyond the eye's data: table `{table}` covers \
                         {table_min_nm}–{table_max_nm} nm; set the grid inside it"
                    ),
                ))
            }
            Err(other) => Err(other.into()),
            Ok(_) => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_past_the_eyes_tables_names_its_end_and_the_tables_range() {
        let mut config = RetinaConfig::tiny();
        config.grid.end_nm = 900.0;
        let message = config.validate().unwrap_err().to_string();
        assert!(
            message.contains("grid.end_nm") && message.contains("390–830 nm"),
            "{message}"
        );
        let mut config = RetinaConfig::tiny();
        config.grid.start_nm = 300.0;
        let message = config.validate().unwrap_err().to_string();
        assert!(
            message.contains("grid.start_nm") && message.contains("390–830 nm"),
            "{message}"
        );
        let mut config = RetinaConfig::tiny();
        config.grid.start_nm = 390.0;
        config.grid.end_nm = 830.0;
        config.validate().unwrap();
    }
}
