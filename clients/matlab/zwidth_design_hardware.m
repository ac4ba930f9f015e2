function r = zwidth_design_hardware(device, target, free, opts)
%ZWIDTH_DESIGN_HARDWARE  The loosest value of one hardware parameter that still renders a target.
%
%   r = zwidth_design_hardware(struct('preset', 'lhifam', 'cable', []), struct('stiffness', 2e4), 'delay')
%   r = zwidth_design_hardware(struct('mass', 0.2, 'damping', 25, 'coulomb_friction', 0.1, 'travel', 0.1), ...
%                              struct('stiffness', 2e4), 'encoder_resolution')
%
%   DEVICE has the HTTP API's device fields in SI units, among them encoder_resolution [m per count],
%   coulomb_friction [N] and travel [m].  TARGET has stiffness [N/m] (and the API's other target fields).
%   FREE is 'sample_time', 'delay', 'damping', 'mass', 'cable.stiffness', 'encoder_resolution' (the
%   coarsest encoder keeping the wall passive, 2*f_c/K_t) or 'coulomb_friction' (the least friction,
%   K_t*q/2).  OPTS are the connection options of ZWIDTH_REQUEST.
%
%   r.status ('optimal', 'infeasible', 'failed'), r.value [SI], r.direction, r.reason; for the
%   encoder and the friction r.quantisation.counts_over_travel (travel/q when device.travel is
%   given), r.quantisation.confirmed (the nonlinear analysis at the answer agrees).
%
%   See also ZWIDTH_ANALYZE, ZWIDTH_DESIGN_STIFFNESS, ZWIDTH_REQUEST.

  if nargin < 4, opts = struct(); end
  body = struct('device', device, 'target', target, 'free', free);
  if ~isfield(opts, 'timeout'), opts.timeout = 180; end   % a hardware design runs tens of exact designs
  r = zwidth_request('POST', '/v1/design/hardware', body, opts);
end
