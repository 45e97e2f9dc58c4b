// The bodies of network_kernels.hpp, included by network_kernels_{baseline,avx2,avx512}.cpp with
// EMADIAG_NN_VARIANT set to the namespace. The operations are those Network::forward and
// Network::mse always did, in the same order.
#include "estimation/network_kernels.hpp"

#include <Eigen/Dense>

namespace emadiag::nn_kernels::EMADIAG_NN_VARIANT {
namespace {

using MatMap = Eigen::Map<const Eigen::MatrixXd>;
using VecMap = Eigen::Map<const Eigen::VectorXd>;

}  // namespace

void forward(const NetworkView& n, const double* x_data, long cols, double* y) {
    const MatMap w1(n.w1, n.hidden, n.inputs), w2(n.w2, n.outputs, n.hidden);
    const VecMap b1(n.b1, n.hidden), b2(n.b2, n.outputs);
    const MatMap x(x_data, n.inputs, cols);
    Eigen::MatrixXd a1 = w1 * x;
    a1.colwise() += b1;
    a1 = a1.array().tanh();  // tansig
    Eigen::MatrixXd z2 = w2 * a1;
    z2.colwise() += b2;
    Eigen::Map<Eigen::MatrixXd>(y, n.outputs, cols) = z2.cwiseMax(-1.0).cwiseMin(1.0);  // satlins
}

double mse(const NetworkView& n, const double* x_data, const double* t_data, long cols, double* grad_data,
           double* a1_data, double* z2_data, bool have_forward) {
    const MatMap w1(n.w1, n.hidden, n.inputs), w2(n.w2, n.outputs, n.hidden);
    const VecMap b1(n.b1, n.hidden), b2(n.b2, n.outputs);
    const MatMap x(x_data, n.inputs, cols), t(t_data, n.outputs, cols);
    const bool keep = a1_data != nullptr && z2_data != nullptr;
    Eigen::MatrixXd a1, z2;
    if (keep && have_forward) {  // the activations of this very forward pass, kept by the caller
        a1 = Eigen::Map<const Eigen::MatrixXd>(a1_data, n.hidden, cols);
        z2 = Eigen::Map<const Eigen::MatrixXd>(z2_data, n.outputs, cols);
    } else {
        a1.noalias() = w1 * x;  // into a1 directly, as the construction from the product did
        a1.colwise() += b1;
        a1 = a1.array().tanh();
        z2.noalias() = w2 * a1;
        z2.colwise() += b2;
        if (keep) {
            Eigen::Map<Eigen::MatrixXd>(a1_data, n.hidden, cols) = a1;
            Eigen::Map<Eigen::MatrixXd>(z2_data, n.outputs, cols) = z2;
        }
    }
    const Eigen::MatrixXd y = z2.cwiseMax(-1.0).cwiseMin(1.0);
    const Eigen::MatrixXd e = y - t;
    const double count = static_cast<double>(e.size());
    const double perf = e.squaredNorm() / count;
    if (grad_data != nullptr) {
        // Backpropagation; satlins' derivative is 1 inside (-1, 1) and 0 where it clamps.
        const Eigen::MatrixXd d2 = (2.0 / count) * e.array() * (z2.array().abs() < 1.0).cast<double>();
        const Eigen::MatrixXd d1 = (w2.transpose() * d2).array() * (1.0 - a1.array().square());
        const Eigen::Index params = w1.size() + b1.size() + w2.size() + b2.size();
        Eigen::Map<Eigen::VectorXd> grad(grad_data, params);
        Eigen::Index at = 0;
        const Eigen::MatrixXd gw1 = d1 * x.transpose();
        grad.segment(at, gw1.size()) = Eigen::Map<const Eigen::VectorXd>(gw1.data(), gw1.size());
        at += gw1.size();
        grad.segment(at, b1.size()) = d1.rowwise().sum();
        at += b1.size();
        const Eigen::MatrixXd gw2 = d2 * a1.transpose();
        grad.segment(at, gw2.size()) = Eigen::Map<const Eigen::VectorXd>(gw2.data(), gw2.size());
        at += gw2.size();
        grad.segment(at, b2.size()) = d2.rowwise().sum();
    }
    return perf;
}

}  // namespace emadiag::nn_kernels::EMADIAG_NN_VARIANT
