//! Experiment: orders of the rear value iteration on the deployed grid.
use std::time::Instant;

use rayon::prelude::*;
use solver::rear::RearConfig;
use solver::semi_lagrangian::{Breakpoints, SampledGame};

#[derive(Clone, Copy)]
struct St {
    base: u32,
    frac: [f32; 3],
    corner: u8,
    scale: f32,
}

fn locate(a: &[f32], x: f32) -> (usize, f32) {
    let n = a.len();
    let x = x.clamp(a[0], a[n - 1]);
    let i = a.partition_point(|&b| b <= x).clamp(1, n - 1) - 1;
    let t = ((x - a[i]) / (a[i + 1] - a[i])).clamp(0.0, 1.0);
    (i, t)
}

struct Problem {
    n: usize,
    m: usize,
    shape: [usize; 3],
    strides: [usize; 3],
    l: Vec<f32>,
    st: Vec<St>,
}

fn build<G: SampledGame>(game: &G, grid: &Breakpoints, h: f32) -> Problem {
    let n = grid.len();
    let m = game.input_count();
    let shape = [grid.axis(0).len(), grid.axis(1).len(), grid.axis(2).len()];
    let strides = [shape[1] * shape[2], shape[2], 1];
    let l: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|node| game.constraint(&grid.node_coordinates(node)))
        .collect();
    let st: Vec<St> = (0..n)
        .into_par_iter()
        .flat_map_iter(|node| {
            let z = grid.node_coordinates(node);
            let idx = [
                node / strides[0],
                (node / strides[1]) % shape[1],
                node % shape[2],
            ];
            (0..m).map(move |i| {
                let zn = game.advance(&z, i, h);
                let mut base = 0;
                let mut frac = [0f32; 3];
                let mut c = [0usize; 3];
                let mut adjacent = true;
                for k in 0..3 {
                    let (b, t) = locate(grid.axis(k), zn[k]);
                    base += b * strides[k];
                    frac[k] = t;
                    if idx[k] == b {
                        c[k] = 0;
                    } else if idx[k] == b + 1 {
                        c[k] = 1;
                    } else {
                        adjacent = false;
                    }
                }
                if adjacent {
                    let a: Vec<f32> = (0..3)
                        .map(|k| if c[k] == 1 { 1.0 - frac[k] } else { frac[k] })
                        .collect();
                    let other = a[0] + (1.0 - a[0]) * (a[1] + (1.0 - a[1]) * a[2]);
                    St {
                        base: base as u32,
                        frac,
                        corner: (c[0] * 4 + c[1] * 2 + c[2]) as u8,
                        scale: if other > 0.0 { 1.0 / other } else { 0.0 },
                    }
                } else {
                    St {
                        base: base as u32,
                        frac,
                        corner: 8,
                        scale: 1.0,
                    }
                }
            })
        })
        .collect();
    Problem {
        n,
        m,
        shape,
        strides,
        l,
        st,
    }
}

impl Problem {
    #[inline(always)]
    fn apply(&self, s: &St, v: &[f32], exclude: bool) -> Option<f32> {
        let b = s.base as usize;
        let [s0, s1, s2] = self.strides;
        let mut c = [
            v[b],
            v[b + s2],
            v[b + s1],
            v[b + s1 + s2],
            v[b + s0],
            v[b + s0 + s2],
            v[b + s0 + s1],
            v[b + s0 + s1 + s2],
        ];
        if exclude && s.corner < 8 {
            if s.scale == 0.0 {
                return None;
            }
            c[s.corner as usize] = 0.0;
        }
        let [t0, t1, t2] = s.frac;
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let p = |o: usize| lerp(lerp(c[o], c[o + 1], t2), lerp(c[o + 2], c[o + 3], t2), t1);
        let w = lerp(p(0), p(4), t0);
        Some(if exclude && s.corner < 8 {
            w * s.scale
        } else {
            w
        })
    }

    fn node(&self, node: usize, v: &[f32], exclude: bool) -> f32 {
        let mut w = self.l[node];
        for s in &self.st[node * self.m..(node + 1) * self.m] {
            if let Some(r) = self.apply(s, v, exclude) {
                w = w.min(r);
            }
        }
        w.min(v[node])
    }
}

fn jacobi(p: &Problem, exclude: bool, tol: f32, max: usize) -> (Vec<f32>, usize, Vec<f32>) {
    let mut v = p.l.clone();
    let mut next = vec![0f32; p.n];
    let mut hist = Vec::new();
    for it in 1..=max {
        let r = next
            .par_iter_mut()
            .enumerate()
            .map(|(node, out)| {
                let w = p.node(node, &v, exclude);
                *out = w;
                v[node] - w
            })
            .reduce(|| 0.0, f32::max);
        std::mem::swap(&mut v, &mut next);
        hist.push(r);
        if it % 500 == 0 {
            eprintln!("  iteration {it}: {r:.3e}");
        }
        if r < tol {
            return (v, it, hist);
        }
    }
    (v, max, hist)
}

fn gauss_seidel(
    p: &Problem,
    exclude: bool,
    orders: &[[bool; 3]],
    tol: f32,
    max: usize,
) -> (Vec<f32>, usize, Vec<f32>) {
    let mut v = p.l.clone();
    let mut hist = Vec::new();
    let [n0, n1, n2] = p.shape;
    for it in 1..=max {
        let rev = orders[(it - 1) % orders.len()];
        let mut r = 0f32;
        for a in 0..n0 {
            let i = if rev[0] { n0 - 1 - a } else { a };
            for b in 0..n1 {
                let j = if rev[1] { n1 - 1 - b } else { b };
                for c in 0..n2 {
                    let k = if rev[2] { n2 - 1 - c } else { c };
                    let node = i * p.strides[0] + j * p.strides[1] + k;
                    let w = p.node(node, &v, exclude);
                    r = r.max(v[node] - w);
                    v[node] = w;
                }
            }
        }
        hist.push(r);
        if it % 100 == 0 {
            eprintln!("  sweep {it}: {r:.3e}");
        }
        if r < tol {
            return (v, it, hist);
        }
    }
    (v, max, hist)
}

fn read_npy(path: &str) -> Vec<f32> {
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    npy.into_vec::<f32>().unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).cloned().unwrap_or_default();
    let tol: f32 = args.get(2).map_or(1e-5, |s| s.parse().unwrap());
    let max: usize = args.get(3).map_or(100_000, |s| s.parse().unwrap());
    let config = RearConfig::from_toml(include_str!("../configs/rear/deployment.toml")).unwrap();
    let grid = config.grid().unwrap();
    let game = config.game();
    let t0 = Instant::now();
    let p = build(&game, &grid, config.solve.period as f32);
    let reference = read_npy("/tmp/base/deployment/value.npy");
    println!("build {:.2} s", t0.elapsed().as_secs_f64());
    let forward = [[false; 3]];
    let two = [[false; 3], [true; 3]];
    let eight: Vec<[bool; 3]> = (0..8)
        .map(|o| [o & 4 != 0, o & 2 != 0, o & 1 != 0])
        .collect();
    let t = Instant::now();
    let (v, it, hist) = match which.as_str() {
        "jacobi" => jacobi(&p, false, tol, max),
        "jacobi-x" => jacobi(&p, true, tol, max),
        "gs" => gauss_seidel(&p, false, &forward, tol, max),
        "gs-x" => gauss_seidel(&p, true, &forward, tol, max),
        "gs2-x" => gauss_seidel(&p, true, &two, tol, max),
        "gs8-x" => gauss_seidel(&p, true, &eight, tol, max),
        "gsb-x" => gauss_seidel(&p, true, &[[true; 3]], tol, max),
        _ => panic!("which"),
    };
    let secs = t.elapsed().as_secs_f64();
    let diff = v
        .iter()
        .zip(&reference)
        .map(|(a, b)| a - b)
        .fold((0f32, 0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
    let positive = v.iter().filter(|&&w| w > 0.0).count();
    let positive_ref = reference.iter().filter(|&&w| w > 0.0).count();
    let tail: f32 = hist[hist.len() - (hist.len() / 10).max(1)..].iter().sum();
    println!(
        "{which}: {it} sweeps, {secs:.1} s, last {:.2e}, sum over last tenth {tail:.2e}; vs reference: min {:.4} max {:.4}; positive {positive} (ref {positive_ref}); plateau {:.4}",
        hist.last().unwrap(),
        diff.0,
        diff.1,
        grid.interpolate(&v, &[10.0, 0.0, 0.0])
    );
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| {
        (v[a] - reference[a])
            .partial_cmp(&(v[b] - reference[b]))
            .unwrap()
    });
    for &node in order.iter().take(15) {
        let z = grid.node_coordinates(node);
        println!(
            "  node ({:.2}, {:.2}, {:.2}): {:.4} vs ref {:.4}",
            z[0], z[1], z[2], v[node], reference[node]
        );
    }
    let mut buckets = [0usize; 6];
    for (a, b) in v.iter().zip(&reference) {
        let d = b - a;
        let k = if d <= 1e-4 {
            0
        } else if d <= 1e-3 {
            1
        } else if d <= 1e-2 {
            2
        } else if d <= 0.1 {
            3
        } else if d <= 1.0 {
            4
        } else {
            5
        };
        buckets[k] += 1;
    }
    println!("  lower than ref by <=1e-4, 1e-3, 1e-2, 0.1, 1, more: {buckets:?}");
    let path = format!("/tmp/study-{which}.bin");
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}
