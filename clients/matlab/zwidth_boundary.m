function r = zwidth_boundary(device, opts)
%ZWIDTH_BOUNDARY  The stability boundary K_cr(B) from B = 0 to B_max and the B allowing the stiffest wall.
%
%   r = zwidth_boundary(struct('preset', 'lhifam'))
%   r = zwidth_boundary(device, struct('points', 80, 'damping_max', 150))
%
%   r = zwidth_boundary(device, struct('controller', struct('mass', 1, 'velocity_filter', ...
%                         struct('kind', 'low_pass', 'cutoff_hz', 50, 'order', 1))))
%
%   OPTS takes points (values of B on the curve, default 50), damping_max
%   [N*s/m] (default B_max), controller (the rendered wall on the boundary: its
%   virtual mass [kg] and velocity_filter, as in ZWIDTH_ANALYZE; default today's
%   wall) and the connection options of ZWIDTH_REQUEST.
%
%   r.points is a struct array with fields damping [N*s/m], critical_stiffness
%   [N/m], crossover_frequency [rad/s] and linear_estimate [N/m]; r.optimum is
%   the point of largest K_cr; r.max_stable_damping is B_max [N*s/m].
%
%   See also ZWIDTH_ANALYZE, ZWIDTH_DESIGN_STIFFNESS, ZWIDTH_REQUEST.

  if nargin < 2, opts = struct(); end
  body = struct('device', device);
  if isfield(opts, 'points'), body.points = opts.points; end
  if isfield(opts, 'damping_max'), body.damping_max = opts.damping_max; end
  if isfield(opts, 'controller') && ~isempty(opts.controller), body.controller = opts.controller; end
  r = zwidth_request('POST', '/v1/analysis/boundary', body, opts);
end
