//! The assignment problem: each of `rows` workers to a different one of `cols ≥ rows` jobs so
//! that the summed weight is largest, solved by the Hungarian algorithm (Kuhn 1955, Munkres
//! 1957) in the shortest-augmenting-path form with potentials, O(rows² · cols).
//!
//! Weights are `(rows, cols)` row-major counts (`usize`); the answer is, per row, its column.
//! Among assignments of equal total any one may be returned.

/// The columns of an assignment of largest total weight: `result[r]` is row `r`'s column, all
/// different. `weights` is `(rows, cols)` row-major with `cols ≥ rows`.
pub fn max_weight_assignment(weights: &[usize], rows: usize, cols: usize) -> Vec<usize> {
    assert!(
        cols >= rows && weights.len() == rows * cols,
        "max_weight_assignment: {} weights for {rows} rows of {cols} columns",
        weights.len()
    );
    if rows == 0 {
        return Vec::new();
    }
    // Minimise cost = largest − weight (non-negative); 1-based as in the textbook form, with
    // column 0 a virtual column holding the row being inserted.
    let largest = weights.iter().copied().max().unwrap_or(0) as i128;
    let cost = |r: usize, c: usize| largest - weights[(r - 1) * cols + (c - 1)] as i128;
    let mut row_potential = vec![0i128; rows + 1];
    let mut col_potential = vec![0i128; cols + 1];
    let mut row_of_col = vec![0usize; cols + 1];
    let mut way = vec![0usize; cols + 1];
    for r in 1..=rows {
        row_of_col[0] = r;
        let mut col = 0usize;
        let mut min_slack = vec![i128::MAX; cols + 1];
        let mut used = vec![false; cols + 1];
        loop {
            used[col] = true;
            let r0 = row_of_col[col];
            let (mut delta, mut next) = (i128::MAX, 0usize);
            for c in 1..=cols {
                if used[c] {
                    continue;
                }
                let slack = cost(r0, c) - row_potential[r0] - col_potential[c];
                if slack < min_slack[c] {
                    min_slack[c] = slack;
                    way[c] = col;
                }
                if min_slack[c] < delta {
                    delta = min_slack[c];
                    next = c;
                }
            }
            for c in 0..=cols {
                if used[c] {
                    row_potential[row_of_col[c]] += delta;
                    col_potential[c] -= delta;
                } else {
                    min_slack[c] -= delta;
                }
            }
            col = next;
            if row_of_col[col] == 0 {
                break;
            }
        }
        // Flip the augmenting path back to the virtual column.
        loop {
            let prev = way[col];
            row_of_col[col] = row_of_col[prev];
            col = prev;
            if col == 0 {
                break;
            }
        }
    }
    let mut result = vec![0usize; rows];
    for c in 1..=cols {
        if row_of_col[c] != 0 {
            result[row_of_col[c] - 1] = c - 1;
        }
    }
    result
}

/// The total weight of `assignment` (row `r` to column `assignment[r]`).
pub fn assignment_weight(weights: &[usize], cols: usize, assignment: &[usize]) -> usize {
    assignment
        .iter()
        .enumerate()
        .map(|(r, &c)| weights[r * cols + c])
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The largest total over every assignment, by trying them all (rows ≤ 8).
    fn exhaustive_best(weights: &[usize], rows: usize, cols: usize) -> usize {
        fn search(w: &[usize], rows: usize, cols: usize, taken: &mut Vec<usize>) -> usize {
            let r = taken.len();
            if r == rows {
                return 0;
            }
            let mut best = 0;
            for c in 0..cols {
                if !taken.contains(&c) {
                    taken.push(c);
                    best = best.max(w[r * cols + c] + search(w, rows, cols, taken));
                    taken.pop();
                }
            }
            best
        }
        search(weights, rows, cols, &mut Vec::new())
    }

    fn is_assignment(a: &[usize], cols: usize) -> bool {
        let mut seen = vec![false; cols];
        a.iter()
            .all(|&c| c < cols && !std::mem::replace(&mut seen[c], true))
    }

    #[test]
    fn a_known_matrix_gets_its_known_best() {
        // The largest total is 9 + 8 + 7 on the anti-diagonal, not the greedy 9 + 5 + 1.
        let w = [1, 2, 9, 3, 8, 5, 7, 4, 1];
        let a = max_weight_assignment(&w, 3, 3);
        assert_eq!(a, vec![2, 1, 0]);
        assert_eq!(assignment_weight(&w, 3, &a), 24);
        // More columns than rows: row 0 takes the lone large weight of the last column.
        let w = [0, 0, 0, 5, 1, 2, 3, 4];
        assert_eq!(max_weight_assignment(&w, 2, 4), vec![3, 2]);
        assert!(max_weight_assignment(&[], 0, 3).is_empty());
    }

    #[test]
    fn twenty_rows_on_a_shuffled_diagonal_are_all_found() {
        let n = 20;
        let perm: Vec<usize> = (0..n).map(|i| (i * 7 + 3) % n).collect();
        let mut w = vec![1usize; n * n];
        for (r, &c) in perm.iter().enumerate() {
            w[r * n + c] = 100;
        }
        assert_eq!(max_weight_assignment(&w, n, n), perm);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn equals_exhaustive_matching_up_to_eight_rows(
            rows in 1usize..=8,
            extra in 0usize..=2,
            seed in any::<u64>(),
            spread in 1usize..50,
        ) {
            let cols = rows + extra;
            // A small spread makes ties, which any best assignment may break.
            let mut s = seed | 1;
            let w: Vec<usize> = (0..rows * cols)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    (s % spread as u64) as usize
                })
                .collect();
            let a = max_weight_assignment(&w, rows, cols);
            prop_assert!(is_assignment(&a, cols), "{a:?}");
            prop_assert_eq!(assignment_weight(&w, cols, &a), exhaustive_best(&w, rows, cols));
        }
    }
}
