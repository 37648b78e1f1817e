//! The bumper panels, as the base reports them on its digital I/O port (`DIO 1` reports).
//!
//! Player's rflex driver (the only public description) knows two layouts, and says the B21r
//! uses the first: **by address**, one DIO address per panel from a base address on (the
//! B21r's 14 panels at 0x40 to 0x4D), the low 4 bits of the value telling which corners of
//! the panel are pressed; and **by bit**, 8 panels per address, one bit each (the Magellan
//! Pro). Both are guessed for our robot until checked on it: which addresses are bumpers is
//! the robot file's business ([`BumperLayout`]).

use super::DioReport;

/// The bits of a panel's value that say it is pressed, by address (its four corners).
const PANEL_CORNERS: u16 = 0x0F;
/// Panels per address, by bit.
const PANELS_PER_ADDRESS: usize = 8;

/// How panels map to digital I/O reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BumperStyle {
    /// One address per panel, pressed when any of the value's low 4 bits is set (B21r).
    Address,
    /// Eight panels per address, one bit each, lowest bit first (Magellan Pro).
    Bit,
}

/// Where the bumper panels report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BumperLayout {
    /// The DIO address of the first panel (or of the first eight, by bit).
    pub first_address: u8,
    /// Panels in all.
    pub count: usize,
    /// How panels map to addresses and bits.
    pub style: BumperStyle,
}

impl BumperLayout {
    /// The B21r per Player: 14 panels at 0x40 to 0x4D, one address each (guessed).
    pub const B21R: Self = Self {
        first_address: 0x40,
        count: 14,
        style: BumperStyle::Address,
    };

    /// The DIO address and value that say panel `index` is pressed (or released), for the
    /// emulator and for tests; `None` when there is no such panel. By bit, the value has
    /// only that panel's bit: other panels of the address read released.
    pub fn report_for(&self, index: usize, pressed: bool) -> Option<(u8, u16)> {
        if index >= self.count {
            return None;
        }
        let (offset, value) = match self.style {
            BumperStyle::Address => (index, if pressed { PANEL_CORNERS } else { 0 }),
            BumperStyle::Bit => (
                index / PANELS_PER_ADDRESS,
                u16::from(pressed) << (index % PANELS_PER_ADDRESS),
            ),
        };
        let address = u8::try_from(usize::from(self.first_address) + offset).ok()?;
        Some((address, value))
    }
}

/// The panels' latest state, from the reports seen so far (all released at first).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bumpers {
    layout: BumperLayout,
    pressed: Vec<bool>,
}

impl Bumpers {
    /// All `layout.count` panels released.
    pub fn new(layout: BumperLayout) -> Self {
        Self {
            layout,
            pressed: vec![false; layout.count],
        }
    }

    /// Takes a DIO report: whether it was a bumper report (others are left to the caller).
    pub fn update(&mut self, report: &DioReport) -> bool {
        let Some(offset) =
            usize::from(report.address).checked_sub(self.layout.first_address.into())
        else {
            return false;
        };
        match self.layout.style {
            BumperStyle::Address => match self.pressed.get_mut(offset) {
                Some(panel) => {
                    *panel = report.value & PANEL_CORNERS != 0;
                    true
                }
                None => false,
            },
            BumperStyle::Bit => {
                let first = offset.saturating_mul(PANELS_PER_ADDRESS);
                if first >= self.pressed.len() {
                    return false;
                }
                for (bit, panel) in self.pressed[first..]
                    .iter_mut()
                    .take(PANELS_PER_ADDRESS)
                    .enumerate()
                {
                    *panel = report.value & (1 << bit) != 0;
                }
                true
            }
        }
    }

    /// Which panels are pressed, by panel index.
    pub fn pressed(&self) -> &[bool] {
        &self.pressed
    }

    /// Whether any panel is pressed.
    pub fn any(&self) -> bool {
        self.pressed.contains(&true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(address: u8, value: u16) -> DioReport {
        DioReport {
            timestamp: 0,
            address,
            value,
        }
    }

    /// Feeds `reports` to fresh bumpers of `layout`: which were taken, and the panels then.
    fn check(layout: BumperLayout, reports: &[(u8, u16)], taken: &[bool], pressed: &[usize]) {
        let mut bumpers = Bumpers::new(layout);
        let got: Vec<bool> = reports
            .iter()
            .map(|&(address, value)| bumpers.update(&report(address, value)))
            .collect();
        assert_eq!(got, taken, "{reports:x?}");
        let got: Vec<usize> = (0..layout.count)
            .filter(|&i| bumpers.pressed()[i])
            .collect();
        assert_eq!(got, pressed, "{reports:x?}");
        assert_eq!(bumpers.any(), !pressed.is_empty());
    }

    #[test]
    fn by_address_each_panel_has_its_address_and_any_corner_presses_it() {
        let b21r = BumperLayout::B21R;
        check(b21r, &[], &[], &[]);
        check(b21r, &[(0x40, 0b0001)], &[true], &[0]);
        check(
            b21r,
            &[(0x43, 0b1000), (0x4D, 0x0F)],
            &[true, true],
            &[3, 13],
        );
        // Only the low 4 bits are corners.
        check(b21r, &[(0x42, 0xF0)], &[true], &[]);
        check(b21r, &[(0x42, 1), (0x42, 0)], &[true, true], &[]);
        // Beyond the panels, and below them: not bumpers.
        check(b21r, &[(0x4E, 1), (0x3F, 1), (0x00, 1)], &[false; 3], &[]);
    }

    #[test]
    fn by_bit_each_address_holds_eight_panels() {
        let layout = BumperLayout {
            first_address: 0x40,
            count: 12,
            style: BumperStyle::Bit,
        };
        check(layout, &[(0x40, 0b1000_0001)], &[true], &[0, 7]);
        // The second address has panels 8 to 11 only; higher bits are ignored.
        check(layout, &[(0x41, 0xFFFF)], &[true], &[8, 9, 10, 11]);
        check(layout, &[(0x42, 1)], &[false], &[]);
    }

    #[test]
    fn the_report_for_a_panel_presses_exactly_that_panel() {
        for style in [BumperStyle::Address, BumperStyle::Bit] {
            let layout = BumperLayout {
                style,
                ..BumperLayout::B21R
            };
            for index in 0..layout.count {
                let (address, value) = layout.report_for(index, true).unwrap();
                check(layout, &[(address, value)], &[true], &[index]);
                let (address, value) = layout.report_for(index, false).unwrap();
                check(layout, &[(address, value)], &[true], &[]);
            }
            assert_eq!(layout.report_for(layout.count, true), None);
        }
        let near_the_end = BumperLayout {
            first_address: 0xFF,
            ..BumperLayout::B21R
        };
        assert_eq!(near_the_end.report_for(1, true), None, "address 0x100");
    }
}
