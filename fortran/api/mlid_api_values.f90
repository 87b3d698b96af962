!> The flat interface's values by name: what a call takes besides its
!> problem (mlid_api_problem), put one by one into the handle's given
!> values (a named_t) and read there by the call by name (named_t's get).
!> Python's _bridge.put clears them and puts a call's values.
!> Conventions: mlid_api_deck's comment.
module mlid_api_values
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  use mlid_handles, only: session_t, handle_session
  use mlid_named, only: named_t, value_t, VALUE_REAL, VALUE_INT, MAXRANK
  implicit none
  private
  public :: mlid_values_clear, mlid_put_real, mlid_put_int, mlid_put_text

contains

  !> Forget the values given before.
  subroutine mlid_values_clear(h, status, msg)
    integer(c_int64_t), intent(in) :: h
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status == MLID_OK) s%given = named_t()
  end subroutine mlid_values_clear

  !> Real value name: x(n) in Fortran order, of rank (0 to 3) and shape dims.
  subroutine mlid_put_real(h, name, n, x, rank, dims, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: name
    integer(c_int), intent(in) :: n, rank, dims(3)   ! 3: mlid_named's MAXRANK
    real(c_double), intent(in) :: x(n)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(value_t) :: v
    call given_value(h, name, VALUE_REAL, n, rank, dims, s, v, status, msg)
    if (status /= MLID_OK) return
    v%r = x
    call s%given%put_value(v)
  end subroutine mlid_put_real

  !> Integer value name, as mlid_put_real.
  subroutine mlid_put_int(h, name, n, x, rank, dims, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: name
    integer(c_int), intent(in) :: n, rank, dims(3)   ! 3: mlid_named's MAXRANK
    integer(c_int), intent(in) :: x(n)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    type(value_t) :: v
    call given_value(h, name, VALUE_INT, n, rank, dims, s, v, status, msg)
    if (status /= MLID_OK) return
    v%i = x
    call s%given%put_value(v)
  end subroutine mlid_put_int

  !> Text value name (UTF-8 bytes, kept as they are).
  subroutine mlid_put_text(h, name, text, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: name, text
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(session_t), pointer :: s
    call handle_session(h, s, status, msg)
    if (status == MLID_OK) call s%given%put(name, text)
  end subroutine mlid_put_text

  !> The session of h and an empty value name of kind, rank and shape dims
  !> (their product n).
  subroutine given_value(h, name, kind, n, rank, dims, s, v, status, msg)
    integer(c_int64_t), intent(in) :: h
    character(len=*), intent(in) :: name
    integer(c_int), intent(in) :: kind, n, rank, dims(MAXRANK)
    type(session_t), pointer, intent(out) :: s
    type(value_t), intent(out) :: v
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    call handle_session(h, s, status, msg)
    if (status /= MLID_OK) return
    if (rank < 0 .or. rank > MAXRANK) then
      status = MLID_ERR_INPUT
      write (msg, '(3a,i0,a,i0)') 'value ''', trim(name), ''' has ', rank, &
        ' dimensions; at most ', MAXRANK
      return
    end if
    if (product(dims(1:rank)) /= n .or. any(dims(1:rank) < 0)) then
      status = MLID_ERR_INPUT
      msg = 'value '''//trim(name)//''': its shape and its number of values disagree'
      return
    end if
    v%name = trim(name)
    v%kind = kind
    v%rank = rank
    v%shape = 1
    v%shape(1:rank) = dims(1:rank)
  end subroutine given_value

end module mlid_api_values
