use hmmseg::hmm::{CovarianceType, Hmm};
use nalgebra::{DMatrix, DVector};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args[2].parse().unwrap();
    let n = 5;
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        if i + 1 < n {
            a[(i, i)] = 0.95;
            a[(i, i + 1)] = 0.05;
        } else {
            a[(i, i)] = 1.0;
        }
    }
    let mut pi = DVector::zeros(n);
    pi[0] = 1.0;
    let model = Hmm::from_params(
        pi,
        a,
        DMatrix::from_element(n, 1, 1.0),
        (0..n)
            .map(|j| DMatrix::from_element(1, 1, j as f64))
            .collect(),
        (0..n)
            .map(|j| vec![DMatrix::from_element(1, 1, 0.2 + 0.05 * j as f64)])
            .collect(),
        CovarianceType::Diag,
    )
    .unwrap();
    let x = model.sample(200, 1).unwrap().0;
    let mut s = 0.0;
    for _ in 0..reps {
        s += match args[1].as_str() {
            "ll" => model.log_likelihood(&x).unwrap(),
            "viterbi" => model.viterbi(&x).unwrap().0,
            "prefix" => model.prefix_log_likelihoods(&x).unwrap()[199],
            _ => 0.0,
        };
    }
    println!("{s}");
}
