function r = zwidth_design_stiffness(device, requirements, opts)
%ZWIDTH_DESIGN_STIFFNESS  The stiffest safe wall: K [N/m] and B [N*s/m] with the required margin.
%
%   r = zwidth_design_stiffness(struct('preset', 'lhifam'))
%   r = zwidth_design_stiffness(device, struct('min_gain_margin_db', 6, 'passivity', true))
%
%   REQUIREMENTS (struct, optional) has the HTTP API's fields: min_gain_margin_db
%   [dB] (default 6), passivity, max_damping [N*s/m], max_stiffness [N/m],
%   max_force [N] with max_penetration [m], quantization [m] with max_force_noise [N].
%   OPTS are the connection options of ZWIDTH_REQUEST.
%
%   r.status is 'optimal', 'infeasible' (r.reason says why) or 'failed';
%   r.stiffness [N/m], r.damping [N*s/m], r.critical_stiffness [N/m],
%   r.gain_margin_db [dB], r.active_constraints, r.sensitivities.
%
%   See also ZWIDTH_ANALYZE, ZWIDTH_BOUNDARY, ZWIDTH_REQUEST.

  if nargin < 2, requirements = []; end
  if nargin < 3, opts = struct(); end
  body = struct('device', device);
  if ~isempty(requirements), body.requirements = requirements; end
  if ~isfield(opts, 'timeout'), opts.timeout = 180; end   % a design solves NLPs and re-checks them exactly
  r = zwidth_request('POST', '/v1/design/stiffness', body, opts);
end
