#pragma once
// Multi-STGAE model definition shared by the Eigen engine (core/) and libtorch training
// (training/): configuration (JSON), tensor names and shapes, weights, loading a model.
// The .hsm file itself: hsm_format.hpp.
// Architecture as implemented: docs/STGAE.md; file format: docs/MODEL_FORMAT.md.
//
// ============================== FORWARD PASS (exact) ==============================
// Notation: N joints (26 for xr26), K = 3 graph subsets, A_k = hs::hand_partition(
// hs::skeleton_by_name(config.skeleton)).A[k] (N x N, symmetric, normalised). Activations
// are [L frames][N joints][C channels]. "conv W,b" on a C_in vector x means W x + b with W
// stored [C_out, C_in] (PyTorch layout). BN(x) = (x - running_mean) / sqrt(running_var +
// 1e-5) * weight + bias, eval mode (running statistics) at inference/validation.
// LeakyReLU slope 0.2. sigma = logistic sigmoid. T = config.window, DT = config.horizon.
//
// Time window W(t): causal padding: frames max(0, t-T+1) .. t (at most T frames, fewer at
// the sequence start); centred padding: all L frames of the window. mean_W = plain mean
// over the frames of W(t). (For the causal model this makes window mode over a long
// sequence identical to streaming frame by frame.)
//
// 1. Input features (6 channels). Raw positions p[t][j] (metres, NaN = missing) are
//    hole-filled first: a missing joint takes its own last valid position; a joint never
//    seen yet takes the filled wrist of that frame, else the filled palm, else the mean
//    of the frame's filled joints; a frame in which no joint has ever been seen is not
//    valid input. x = filled positions, w[t] = x[t][wrist] (wrist = the joint named
//    "wrist", else the skeleton's root; palm = the joint named "palm", if any).
//      f[t][j][0..2] = (x[t][j] - w[t]) / shape_scale_m            (0.1 m)
//      f[t][j][3..5] = (x[t][j] - x[t-1][j]) / velocity_scale_m    (0.01 m); 0 for t = 0
//    (t = 0 is the first frame of the sequence/window, or the first frame after reset.)
// 2. STGCB block (prefix P, C_in -> C_out, temporal kernel kt, padding):
//    a. h[t][v] = ReLU(BN_{P.gcn.bn}(W_{P.gcn.conv} f[t][v] + b))   (K*C_out channels,
//       channel index k*C_out + c belongs to subset k)
//    b. M_k(t) = A_k (+ B_k if attention has B) (+ C_k(t) if attention has C), where
//       B_k = P.B[k] and C_k(t) is row-softmax (over w) of the score S_k(t)[v][w]:
//       - "dot": q_s = W_q,k f[s][v], k_s = W_k,k f[s][w] (rows k*d..k*d+d-1 of
//         P.att.q.weight / P.att.k.weight, d = max(1, C_in/2), no bias);
//         S_k(t)[v][w] = mean_{s in W(t)} (q_s[v] . k_s[w]) / sqrt(d).
//       - "gat": e[v] = W_emb,k (mean_{s in W(t)} f[s][v])  (d values; P.att.emb.weight
//         rows k*d..), a = P.att.a[k] (2d values);
//         S_k(t)[v][w] = LeakyReLU(a[0:d] . e[v] + a[d:2d] . e[w]).
//       C_k(t)[v][w] = exp(S[v][w]) / sum_w' exp(S[v][w']).
//    c. g[t][w][c] = sum_k sum_v h[t][v][k*C_out + c] * M_k(t)[v][w]
//    d. u[t] = sum_{j=0}^{kt-1} W_{P.tcn.conv}[:, :, j] g[t + j - o] + b, with g = 0 outside
//       [0, L): causal o = kt-1 (frame t uses t-kt+1..t), centred o = (kt-1)/2, valid
//       (prediction head only) o = 0 and output frames t = 0..L-kt (the residual of output
//       frame t then reads input frame t+kt-1, the newest frame under the kernel).
//    e. z[t] = BN_{P.tcn.bn}(u[t]), then ReLU — except in the LAST block of each decoder
//       (den.last, pre.last), which stays linear.
//    f. out[t][v] = z[t][v] + BN_{P.res.bn}(W_{P.res.conv} f[t][v] + b)   (no ReLU after)
// 3. Gate (prefix G, C channels, hc = max(1, C/2)), on x = [L][N][C]:
//    pt[t][v] = mean_{s in W(t)} x[s][v]          (pooled over time, per joint)
//    pj[t]    = mean_v x[t][v]                     (pooled over joints, per frame)
//    zt = ReLU(BN_{G.shared.bn}(W_{G.shared.conv} pt + b)), zj likewise (shared weights)
//    gt = sigma(W_{G.time.conv} zt + b), gj = sigma(W_{G.joint.conv} zj + b)   (C each)
//    out[t][v] = ReLU(BN_{G.bn}(x[t][v] + x[t][v] * gt[t][v] * gj[t]))   (elementwise)
// 4. Network: E = enc blocks (kernel temporal_kernel, config padding) on f; H = enc_gate(E)
//    if gates else E.
//    Denoise: D = den blocks on H (same kernel/padding); Xhat[t] = x[t] + shape_scale_m *
//    D[t] (3 channels = xyz offset).
//    Predict (if predict): Pin = pre_gate(H) if gates else H.
//      causal: from the newest frame only: z = W_{pre.lift} Pin[L-1][v] + b (DT*C values,
//              index i*C + c = future frame i), Z[i][v][c] = z[i*C + c] + PE[i][c];
//              pre blocks on the DT frames with temporal kernel 1 (means over the DT frames).
//      centred: Z = block pre.head (C -> C, kernel T-DT+1, valid padding; needs L = T) on
//              Pin, + PE; pre blocks with temporal_kernel, centred padding over DT frames.
//      PE[i][2m] = sin(i / 10000^(2m/C)), PE[i][2m+1] = cos(i / 10000^(2m/C)), i = 0..DT-1,
//      C = predict_decoder_channels[0], broadcast over joints.
//      Yhat[i] = Xhat[L-1] + shape_scale_m * Q[i] (Q = pre blocks' 3-channel output).
// ==================================================================================
//
// Tensor names (stgae_tensor_specs lists them in this order, with shapes):
//   for each block prefix P in enc.{i}. (i < encoder_channels.size()-1), den.{i}., then
//   (predict) pre.head. (centred only), pre.{i}.:
//     P+"gcn.conv.weight" [K*Cout, Cin]   P+"gcn.conv.bias" [K*Cout]
//     P+"gcn.bn.{weight,bias,running_mean,running_var}" [K*Cout]
//     P+"B" [K, N, N]                                   (attention "A+B", "A+B+C")
//     P+"att.q.weight", P+"att.k.weight" [K*d, Cin]      ("A+B+C", c_variant "dot")
//     P+"att.emb.weight" [K*d, Cin], P+"att.a" [K, 2*d]  ("A+B+C", c_variant "gat")
//     P+"tcn.conv.weight" [Cout, Cout, kt]  P+"tcn.conv.bias" [Cout]  P+"tcn.bn.*" [Cout]
//     P+"res.conv.weight" [Cout, Cin]  P+"res.conv.bias" [Cout]  P+"res.bn.*" [Cout]
//   gates (if gates) G in "enc_gate.", "pre_gate." (the latter only with predict), C = latent:
//     G+"shared.conv.weight" [hc, C]  G+"shared.conv.bias" [hc]  G+"shared.bn.*" [hc]
//     G+"time.conv.weight" [C, hc]  G+"time.conv.bias" [C]
//     G+"joint.conv.weight" [C, hc] G+"joint.conv.bias" [C]   G+"bn.*" [C]
//   causal predict: "pre.lift.weight" [DT*C, C], "pre.lift.bias" [DT*C]
//   ("bn.*" = weight, bias, running_mean, running_var.)
#include "handsteady/error.hpp"

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

// The network family a configuration describes: Multi-STGAE (this header's forward pass;
// STGAE = the same with predict false and no gates) or the directed-graph refinement
// network (dgn_model.hpp documents its forward pass).
enum class StgaeFamily { MultiStgae, Dgn };
enum class StgaePadding { Centred, Causal };
// DGN temporal module: LSTM over each joint/bone (bidirectional when centred, forward only
// when causal) or a residual temporal convolution (temporal_kernel).
enum class DgnTemporal { Lstm, Tcn };
enum class StgaeAttention { A, AB, ABC };
enum class StgaeCVariant { Dot, Gat };

struct StgaeConfig {
  StgaeFamily family = StgaeFamily::MultiStgae;
  std::string skeleton = "xr26";  // hs::skeleton_by_name
  int window = 16;                // T, frames
  int horizon = 3;                // DT, frames predicted after the last input frame
  double rate_hz = 30.0;          // model frame rate (input is resampled to it outside)
  std::vector<int> encoder_channels{6, 32, 64, 64};          // [0] must be 6
  std::vector<int> denoise_decoder_channels{64, 32, 32, 3};  // [0] = encoder out, last 3
  std::vector<int> predict_decoder_channels{64, 32, 3};      // [0] = encoder out, last 3
  int temporal_kernel = 5;        // odd
  StgaePadding padding = StgaePadding::Causal;
  StgaeAttention attention = StgaeAttention::ABC;
  StgaeCVariant c_variant = StgaeCVariant::Dot;
  bool gates = true;
  bool predict = true;            // false = denoise only (STGAE-style)
  // DGN only (family dgn): the temporal module between encoder and decoders.
  DgnTemporal temporal = DgnTemporal::Tcn;
  int temporal_layers = 2;
  double shape_scale_m = 0.1;     // feature/offset unit of the wrist-relative shape
  double velocity_scale_m = 0.01; // feature unit of the per-frame displacement
  // Free-form JSON object (training data, epochs, metrics, ...), kept verbatim; "{}" if none.
  std::string meta_json = "{}";

  int joint_count() const;        // N of the skeleton
  int latent_channels() const { return encoder_channels.back(); }
  // Multi-STGAE's published centred prediction head (T latent frames -> DT): it reads
  // exactly `window` frames, so window mode needs L = T and horizon <= window.
  bool centred_head() const {
    return family == StgaeFamily::MultiStgae && predict && padding == StgaePadding::Centred;
  }
};

// JSON keys: family ("multi-stgae"|"dgn"; written only for dgn), skeleton, window, horizon, rate_hz, encoder_channels, denoise_decoder_channels,
// predict_decoder_channels, temporal_kernel, padding ("centred"|"causal"), attention
// ("A"|"A+B"|"A+B+C"), c_variant ("dot"|"gat"), gates, predict, shape_scale_m,
// velocity_scale_m, meta (object); dgn also temporal ("lstm"|"tcn"), temporal_layers, and
// refuses attention, c_variant and gates (they do not apply). Missing keys take the defaults above; unknown keys,
// wrong types and invalid values throw InputError naming source and key.
StgaeConfig parse_stgae_config(std::string_view json, const std::string& source = "");
std::string to_json(const StgaeConfig& config);
// True when the two configurations describe one network (equal but for their meta): the
// weights of one fit the other (fine-tuning from it, teaching it, blending with it).
bool same_network(const StgaeConfig& a, const StgaeConfig& b);
// Throws InputError (field = the key) when the configuration is inconsistent.
void validate_stgae_config(const StgaeConfig& config, const std::string& source = "");

struct TensorSpec {
  std::string name;
  std::vector<int> shape;
  std::size_t numel() const;
};
std::string shape_text(const std::vector<int>& shape);  // "[3, 4]", for error messages
// Every tensor of the model, in file order (see the list above).
std::vector<TensorSpec> stgae_tensor_specs(const StgaeConfig& config);

struct Tensor {
  std::vector<int> shape;
  std::vector<float> data;  // row-major (C order), like PyTorch's contiguous layout
};

struct StgaeWeights {
  std::map<std::string, Tensor, std::less<>> tensors;
  // Throws std::out_of_range naming the tensor when absent.
  const Tensor& at(std::string_view name) const;
};
// Throws InputError (field = tensor name) when a tensor is missing, unexpected, has the
// wrong shape or a non-finite value, or a running_var is negative.
void check_stgae_weights(const StgaeConfig& config, const StgaeWeights& weights,
                         const std::string& source = "");
// Deterministic random weights for tests (BN statistics and affine terms near identity,
// conv weights ~ U(-a, a) with a = scale / sqrt(fan_in), B ~ U(-0.1, 0.1)).
StgaeWeights random_stgae_weights(const StgaeConfig& config, std::uint64_t seed, double scale = 1.0);

// Reference pair verified on load: window frames of raw positions (NaN = missing joint)
// and the expected outputs, frame-major then joint then xyz.
struct StgaeReference {
  int frames = 0;               // = config.window
  std::vector<float> input;     // frames * N * 3
  std::vector<float> denoised;  // frames * N * 3
  std::vector<float> predicted; // horizon * N * 3 (empty when !predict)
};

template <class Scalar>
class StgaeNet;  // prepared (BN-folded) parameters, stgae_engine.hpp

struct StgaeModel {
  StgaeConfig config;
  StgaeWeights weights;
  StgaeReference reference;
  std::shared_ptr<const StgaeNet<float>> net;  // ready for the engine
};

// Builds a model in memory (checks config and weights, prepares the float net).
// verify: also run the reference and compare (tolerance 1e-4 * max(1, |expected|)).
std::shared_ptr<const StgaeModel> make_stgae_model(StgaeConfig config, StgaeWeights weights,
                                                   StgaeReference reference, bool verify = true,
                                                   const std::string& source = "");
// Computes the reference outputs for an input with the engine in double precision.
StgaeReference make_stgae_reference(const StgaeConfig& config, const StgaeWeights& weights,
                                    std::vector<float> input);
// A deterministic synthetic hand input (frames x N x 3, metres) for references/tests.
std::vector<float> synthetic_hand_input(const StgaeConfig& config, int frames, std::uint64_t seed);

// Loading a runnable model: the .hsm file (hsm_format.hpp: read_hsm) + the float net +
// the reference check (verify). Any defect -> InputError naming the source (file), the part
// (header/config/tensor name/reference/checksum) and byte offset.
std::shared_ptr<const StgaeModel> parse_hsm(std::span<const std::uint8_t> bytes,
                                            const std::string& source, bool verify = true);
std::shared_ptr<const StgaeModel> load_hsm(const std::filesystem::path& path, bool verify = true);
// Writes the model to `path` + ".tmp", loads and verifies that file, then renames it to
// `path`: a model file that is there loads, and an interrupted run leaves no torn one.
void save_hsm_verified(const std::filesystem::path& path, const StgaeConfig& config, const StgaeWeights& weights,
                       const StgaeReference& reference);

}  // namespace hs
