!> The flat interface's problem: what a call runs on, set part by part
!> into a handle (mlid_problem's problem_t), each part by its arguments'
!> names, once for any number of calls.  A part set again replaces the
!> one before.  Conventions: mlid_api_deck's comment.
module mlid_api_problem
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_handles, only: session_t, handle_session
  use mlid_params, only: ties_of
  use mlid_problem, only: PART_MODEL, PART_PARAMS, PART_RECORD, PART_OPTIONS, PART_EXTRAS
  implicit none
  private
  public :: mlid_set_model, mlid_set_params, mlid_set_record, mlid_set_options, mlid_set_extras

contains

  !> The model: kind (mlid_model_factory), sizes, noise inputs, constants.
  subroutine mlid_set_model(h, mkind, nx, nu, ny, nw, nic, iconst, nrc, rconst, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: mkind, nx, nu, ny, nw, nic, nrc, iconst(nic)
    real(c_double), intent(in) :: rconst(nrc)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%problem%has(PART_MODEL) = .true.
    s%problem%mkind = mkind
    s%problem%nx = nx
    s%problem%nu = nu
    s%problem%ny = ny
    s%problem%nw = nw
    s%problem%iconst = iconst
    s%problem%rconst = rconst
  end subroutine mlid_set_model

  !> The parameters theta0 (mlid_models' layout), which are free (isfree:
  !> each one's place in the order of free, 0 fixed) and their affine ties
  !> (ntie terms; mlid_api_deck's comment).
  subroutine mlid_set_params(h, nth, theta0, isfree, ntie, mtie, tie_to, tie_from, tie_scale, &
                             tie_offset, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nth, ntie, mtie, isfree(nth), tie_to(mtie), tie_from(mtie)
    real(c_double), intent(in) :: theta0(nth), tie_scale(mtie), tie_offset(nth)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%problem%has(PART_PARAMS) = .true.
    s%problem%theta = theta0
    s%problem%isfree = isfree
    s%problem%tie = ties_of(ntie, tie_to, tie_from, tie_scale, tie_offset)
  end subroutine mlid_set_params

  !> The record, one column per sample, and each manoeuvre's first sample.
  subroutine mlid_set_record(h, nt, nu, ny, t, u, y, nseg, segstart, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nt, nu, ny, nseg, segstart(nseg)
    real(c_double), intent(in) :: t(nt), u(nu, nt), y(ny, nt)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%problem%has(PART_RECORD) = .true.
    s%problem%t = t
    s%problem%u = u
    s%problem%y = y
    s%problem%segstart = segstart
  end subroutine mlid_set_record

  !> The options, as mlid_option_set made them.
  subroutine mlid_set_options(h, iopt, ropt, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: iopt(16)
    real(c_double), intent(in) :: ropt(16)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%problem%has(PART_OPTIONS) = .true.
    s%problem%iopt = iopt
    s%problem%ropt = ropt
  end subroutine mlid_set_options

  !> The next fit's extras: a priori values (all parameters) and weight
  !> (free x free), and bounds (all parameters); each used when its use_* is
  !> 1.  The fit takes them (a fit after it has none unless set again).
  subroutine mlid_set_extras(h, nth, nf, use_prior, prior, pweight, use_bounds, lower, upper, &
                             status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(in) :: nth, nf, use_prior, use_bounds
    real(c_double), intent(in) :: prior(nth), pweight(nf, nf), lower(nth), upper(nth)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    s%problem%has(PART_EXTRAS) = .true.
    s%problem%use_prior = use_prior
    s%problem%use_bounds = use_bounds
    s%problem%prior = prior
    s%problem%pweight = pweight
    s%problem%lower = lower
    s%problem%upper = upper
  end subroutine mlid_set_extras

end module mlid_api_problem
