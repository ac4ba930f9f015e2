function r = zwidth_design_stiffness(device, requirements, opts)
%ZWIDTH_DESIGN_STIFFNESS  The stiffest safe wall: K [N/m] and B [N*s/m] with the required margin.
%
%   r = zwidth_design_stiffness(struct('preset', 'lhifam'))
%   r = zwidth_design_stiffness(device, struct('min_gain_margin_db', 6, 'passivity', true))
%
%   REQUIREMENTS (struct, optional) has the HTTP API's fields: min_gain_margin_db
%   [dB] (default 6), passivity, max_damping [N*s/m], max_stiffness [N/m],
%   max_force [N] with max_penetration [m], quantization [m] with max_force_noise [N],
%   and workspace: one (K, B) safe at every pose and normal of a multi-DOF device
%   (the device then gives only sample_time and delay; its mass is not used):
%
%     ws = struct('kinematics', struct('preset', 'planar-2link'), ...
%                 'poses', struct('latin_hypercube', struct('samples', 5, 'seed', 3)), ...
%                 'normals', 'worst', 'verify_factor', 2);
%     r = zwidth_design_stiffness(struct('mass', 1, 'damping', 0, 'sample_time', 1e-3, ...
%             'delay', 1e-3), struct('min_gain_margin_db', 1, 'workspace', ws));
%
%   r.workspace then holds the worst cases, the exchanges and the denser set's
%   verification_margin (K_cr/K - 1 at its worst pose); r.status is 'unsafe' when
%   that margin is negative.
%   OPTS are the connection options of ZWIDTH_REQUEST.
%
%   r.status is 'optimal', 'infeasible' (r.reason says why), 'unsafe' or 'failed';
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
