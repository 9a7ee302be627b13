//! The Newton matrix: a fixed compressed-column pattern built from the kernels' blocks, and
//! faer's sparse LU with the symbolic analysis (fill-reducing ordering, elimination structure)
//! done once per pattern and the numeric factors and scratch memory reused every iteration.

use dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::dyn_stack;
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

pub struct NewtonMatrix {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    pub values: Vec<f64>,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    scratch: MemBuffer,
    pub numeric_factorizations: usize,
    pub symbolic_factorizations: usize,
}

impl NewtonMatrix {
    /// Pattern from dense local blocks (each a list of global indices); returns the matrix and,
    /// per block, the row-major value positions of its `n × n` entries.
    pub fn from_blocks(n: usize, blocks: &[&[usize]]) -> (Self, Vec<Vec<usize>>) {
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for b in blocks {
            for &j in b.iter() {
                cols[j].extend_from_slice(b);
            }
        }
        // Every diagonal entry exists so a pivot can always be chosen structurally.
        for (j, c) in cols.iter_mut().enumerate() {
            c.push(j);
            c.sort_unstable();
            c.dedup();
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        for c in &cols {
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        let positions = blocks
            .iter()
            .map(|b| {
                let m = b.len();
                let mut p = vec![0; m * m];
                for (i, &gi) in b.iter().enumerate() {
                    for (j, &gj) in b.iter().enumerate() {
                        let col = &row_idx[col_ptr[gj]..col_ptr[gj + 1]];
                        p[i * m + j] =
                            col_ptr[gj] + col.binary_search(&gi).expect("entry in pattern");
                    }
                }
                p
            })
            .collect();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_lu(sym, Default::default()).expect("symbolic LU");
        let par = Par::Seq;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, par),
        ]);
        let nnz = row_idx.len();
        let m = NewtonMatrix {
            n,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
            symbolic,
            numeric: NumericLu::new(),
            scratch: MemBuffer::new(req),
            numeric_factorizations: 0,
            symbolic_factorizations: 1,
        };
        (m, positions)
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    pub fn clear(&mut self) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Numeric LU of the current values; the symbolic analysis is reused.
    pub fn factor(&mut self) -> Result<(), String> {
        let sym = SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let a = SparseColMatRef::new(sym, &self.values);
        self.symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                a,
                Par::Seq,
                MemStack::new(&mut self.scratch),
                Default::default(),
            )
            .map_err(|e| format!("sparse LU failed: {e:?}"))?;
        self.numeric_factorizations += 1;
        Ok(())
    }

    /// Solves `A x = rhs` in place with the last factorization.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        let mat = MatMut::from_column_major_slice_mut(rhs, self.n, 1);
        lu.solve_in_place_with_conj(Conj::No, mat, Par::Seq, MemStack::new(&mut self.scratch));
    }

    /// Dense copy (for tests and diagnostics only).
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; self.n]; self.n];
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                d[self.row_idx[p]][j] = self.values[p];
            }
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assembles_blocks_and_solves() {
        let b1 = [0usize, 1];
        let b2 = [1usize, 2];
        let (mut m, pos) = NewtonMatrix::from_blocks(3, &[&b1, &b2]);
        // [[4,1,0],[1,5,2],[0,2,6]] from two overlapping blocks.
        let k1 = [4.0, 1.0, 1.0, 2.0];
        let k2 = [3.0, 2.0, 2.0, 6.0];
        for (p, v) in pos[0].iter().zip(k1) {
            m.values[*p] += v;
        }
        for (p, v) in pos[1].iter().zip(k2) {
            m.values[*p] += v;
        }
        m.factor().unwrap();
        let mut x = [1.0, 2.0, 3.0];
        m.solve(&mut x);
        let a = m.to_dense();
        for i in 0..3 {
            let r: f64 = (0..3).map(|j| a[i][j] * x[j]).sum();
            assert!((r - [1.0, 2.0, 3.0][i]).abs() < 1e-14);
        }
        m.factor().unwrap();
        assert_eq!(
            (m.numeric_factorizations, m.symbolic_factorizations),
            (2, 1)
        );
    }
}
