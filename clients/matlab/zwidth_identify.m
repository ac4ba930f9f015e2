function r = zwidth_identify(data, params, opts)
%ZWIDTH_IDENTIFY  A device and its uncertainty from measurements (POST /v1/identify).
%
%   A time series at the loop's rate (force [N] held by the ZOH, encoder position [m], from rest):
%     r = zwidth_identify(struct('kind', 'time_series', 'sample_time', 1e-3, 'force', u, 'position', x))
%   A measured X/F [m/N] at w [rad/s], delay included:
%     r = zwidth_identify(struct('kind', 'frequency_response', 'frequency', w, 'real', real(h), 'imag', imag(h)))
%   With options:
%     r = zwidth_identify(data, struct('model', 'cable', 'friction', true, 'known', struct('delay', 5e-4)))
%
%   PARAMS (struct, optional): model ('rigid' | 'cable' | 'auto', default auto), known (struct of
%   parameters held fixed), friction (logical, time series), confidence (default 0.95), sample_time
%   (the device's T for a frequency response), max_delay [s].  OPTS are the connection options of
%   ZWIDTH_REQUEST.  Vectors are sent as JSON arrays (give at least 2 values).
%
%   r.status is 'identified' or 'failed' (r.reason says why); r.model, r.reason (why this model),
%   r.device (a device struct every other function accepts), r.parameters.<name>.value/std_error/interval,
%   r.uncertainty, r.fit.nrmse, r.fit.residual_whiteness, r.comparison, r.warnings.
%   jsondecode turns the dotted names into valid field names: parameters.cable_motor_mass,
%   uncertainty.device_mass, uncertainty.device_cable_stiffness ...
%
%   See also ZWIDTH_DESIGN_STIFFNESS, ZWIDTH_ANALYZE, ZWIDTH_REQUEST.

  if nargin < 2, params = []; end
  if nargin < 3, opts = struct(); end
  body = struct('data', data);
  if ~isempty(params)
    names = fieldnames(params);
    for k = 1:numel(names)
      body.(names{k}) = params.(names{k});
    end
  end
  if ~isfield(opts, 'timeout'), opts.timeout = 180; end   % several least-squares fits
  r = zwidth_request('POST', '/v1/identify', body, opts);
end
