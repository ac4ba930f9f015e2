function r = zwidth_analyze(device, controller, opts)
%ZWIDTH_ANALYZE  Critical stiffness K_cr(B), every crossover, margin and passivity of a wall.
%
%   r = zwidth_analyze(struct('preset', 'lhifam', 'delay', 1e-3))
%   r = zwidth_analyze(device, struct('stiffness', 3500, 'damping', 5))
%   r = zwidth_analyze(device, [], struct('method', 'linear', 'url', 'http://lab-server:8000'))
%
%   DEVICE is a struct with the HTTP API's device fields in SI units (preset,
%   mass [kg], damping [N*s/m], sample_time [s], delay [s], cable, human,
%   force_sensor, encoder_resolution [m per count], coulomb_friction [N], travel [m]).
%   With encoder_resolution or coulomb_friction the answer has r.nonlinear: the passive
%   limit min(2b/T, 2f_c/q), the predicted limit cycle and the regime.  CONTROLLER is the wall K [N/m], B [N*s/m] to check ([] for
%   K_cr at B = 0), optionally the rendered wall's virtual mass and velocity filter:
%     struct('stiffness', 2e4, 'damping', 50, 'mass', -1, ...
%            'velocity_filter', struct('kind', 'low_pass', 'cutoff_hz', 50, 'order', 1))
%   (kinds: backward_difference, low_pass with cutoff_hz and order 1|2, moving_average with
%   samples, transfer_function with numerator and denominator); then r.mass_range.min/max [kg]
%   is the stable virtual mass at (K, B).  OPTS takes method ('linear', 'grid', 'exact', 'reference')
%   and the connection options of ZWIDTH_REQUEST.
%
%   r.critical_stiffness [N/m], r.crossover_frequency [rad/s], r.gain_margin_db [dB],
%   r.stable, r.passive, r.linear_estimate [N/m] (chapter eq. 10), r.method, r.elapsed_ms.
%
%   See also ZWIDTH_BOUNDARY, ZWIDTH_DESIGN_STIFFNESS, ZWIDTH_REQUEST.

  if nargin < 2, controller = []; end
  if nargin < 3, opts = struct(); end
  body = struct('device', device);
  if ~isempty(controller), body.controller = controller; end
  if isfield(opts, 'method'), body.method = opts.method; end
  r = zwidth_request('POST', '/v1/analysis/stability', body, opts);
end
