//! From commanded thruster words to actual valve edges: the command at sample k holds until
//! sample k+1 (1 ms resolution at 1 kHz); a valve opens `open_delay_ms` after a commanded
//! rising edge and closes `close_delay_ms` after a falling one (seed ch. 3.6). Delays may put
//! edges between samples; a pulse that would close before it opens never opens.
use reference_f64::satellite::MAX_THRUSTERS;

/// One actual valve edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValveEdge {
    /// Time of the edge, ms since the recording's start.
    pub t_ms: f64,
    /// Thruster index, 0-based.
    pub thruster: u8,
    /// true = opens, false = closes.
    pub opens: bool,
}

/// Actual valve edges for commanded `words` at `times_ms`, sorted by time (stable: at equal
/// times thruster order, closes before opens of the same thruster).
pub fn valve_edges(
    times_ms: &[u64],
    words: &[u16],
    open_delay_ms: f64,
    close_delay_ms: f64,
) -> Vec<ValveEdge> {
    let mut edges = Vec::new();
    let n = times_ms.len().min(words.len());
    for th in 0..MAX_THRUSTERS {
        let bit = 1u16 << th;
        let mut on_since: Option<f64> = None;
        let mut prev = false;
        for k in 0..n {
            let now = words[k] & bit != 0;
            let t = times_ms[k] as f64;
            if now && !prev {
                on_since = Some(t + open_delay_ms);
            } else if !now && prev {
                if let Some(t_open) = on_since.take() {
                    let t_close = t + close_delay_ms;
                    if t_close > t_open {
                        edges.push(ValveEdge {
                            t_ms: t_open,
                            thruster: th as u8,
                            opens: true,
                        });
                        edges.push(ValveEdge {
                            t_ms: t_close,
                            thruster: th as u8,
                            opens: false,
                        });
                    }
                }
            }
            prev = now;
        }
        // Still commanded open at the last sample: it opens and stays open.
        if let Some(t_open) = on_since {
            edges.push(ValveEdge {
                t_ms: t_open,
                thruster: th as u8,
                opens: true,
            });
        }
    }
    edges.sort_by(|a, b| {
        a.t_ms
            .total_cmp(&b.t_ms)
            .then(a.opens.cmp(&b.opens))
            .then(a.thruster.cmp(&b.thruster))
    });
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_shift_edges_and_swallow_too_short_pulses() {
        let t: Vec<u64> = (0..10).collect();
        let w = [0, 1, 1, 1, 0, 0, 2, 0, 0, 0];
        let e = valve_edges(&t, &w, 2.5, 0.5);
        // Thruster 1: commanded 1..4 -> open 3.5, close 4.5. Thruster 2: 6..7 -> 8.5 > 7.5: never.
        assert_eq!(e.len(), 2);
        assert_eq!((e[0].t_ms, e[0].opens, e[0].thruster), (3.5, true, 0));
        assert_eq!((e[1].t_ms, e[1].opens, e[1].thruster), (4.5, false, 0));
    }
}
